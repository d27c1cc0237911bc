"""Interrupting an ``abb-sim`` command as Ctrl-C would, once it has written some partitions."""

import signal
import subprocess
import sys
import time


def interrupt_after_parts(argv, parts_dir, parts: int = 3, timeout_s: float = 60.0):
    """Run ``abb-sim argv``; SIGINT it once ``parts_dir`` holds ``parts`` part-*.parquet files
    (or after ``timeout_s``). Return (exit code, stderr text).

    SIGINT is restored to its default in the child, so it is interrupted even when the test
    runs with SIGINT ignored (a background job of a non-interactive shell), which the command
    would otherwise inherit.
    """
    proc = subprocess.Popen([sys.executable, '-m', 'abb_ros.cli', *argv],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and proc.poll() is None:
            if len(list(parts_dir.glob('part-*.parquet'))) >= parts:
                break
            time.sleep(0.01)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc.returncode, err.decode()
