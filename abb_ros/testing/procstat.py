"""CPU time and memory of a process from /proc (Linux), for the benchmarks of the nodes."""

from __future__ import annotations

import os

CLK_TCK = os.sysconf('SC_CLK_TCK')
PAGE_SIZE = os.sysconf('SC_PAGE_SIZE')


def cpu_seconds(pid: int) -> float:
    """Return the user + system CPU time [s] of process ``pid`` so far."""
    with open(f'/proc/{pid}/stat') as f:
        fields = f.read().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK  # utime, stime


def rss_bytes(pid: int) -> int:
    """Return the resident set size [bytes] of process ``pid``."""
    with open(f'/proc/{pid}/statm') as f:
        return int(f.read().split()[1]) * PAGE_SIZE
