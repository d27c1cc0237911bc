"""Wall time of `abb-sim basin`: a 32 x 32 two-ball basin of 3 s runs at P3 on 2 local workers.

Printed (not asserted), with the load average beside every figure (the machine is shared:
other work on its 2 cores slows every figure here):

(a) the baseline, measured in the same run: one start run in this process
    (``app.headless.run_scenario``, abb-sim run's integration, 3 s at 10 kHz), and the serial
    time it projects for all starts;
(b) the whole command ``abb-sim basin --res 32x32 --duration 3 --workers 2``, timed from the
    command line's call to its return: cluster start, the workers' loading of the compiled
    kernels, 1024 runs, the table, summary and picture; and its ratio to (a)'s projection;
(c) the CPU time the command used: its worker processes' (children of this process, counted
    once they have exited) and this process's own. On a loaded machine the wall time of (b)
    is set by the share of the 2 cores the workers get; the CPU time is what the study costs.

Run with the installed package: ``.venv/bin/python benchmarks/bench_basin.py [--quick]
[--keep DIR]`` (``--quick``: 8 x 8; ``--keep``: leave the study in DIR).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import resource
import shutil
import tempfile
import time

from abb_ros.app.headless import run_scenario
from abb_ros.cli import main
from abb_ros.io.files.scenario import load_scenario

DURATION = 3.0


def load() -> str:
    """The 1, 5 and 15 minute load averages, as printed beside each figure."""
    return 'load average %.2f %.2f %.2f' % os.getloadavg()


def one_start() -> float:
    """Wall time [s] of one start run in this process (kernels loaded first)."""
    scen = load_scenario('p3')
    scen.duration = DURATION
    run_scenario(scen)            # loads the compiled kernels from numba's cache
    t0 = time.perf_counter()
    run_scenario(scen)
    return time.perf_counter() - t0


def _cpu(who) -> float:
    usage = resource.getrusage(who)
    return usage.ru_utime + usage.ru_stime


def basin(res: int, workers: int, out: str) -> tuple[float, dict]:
    """Run the command; return its wall time [s] and its summary."""
    argv = ['basin', '--res', f'{res}x{res}', '--duration', str(DURATION), '--workers',
            str(workers), '--out', out, '--no-progress', '--json']
    buf = io.StringIO()
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(buf):
        code = main(argv)
    wall = time.perf_counter() - t0
    if code != 0:
        raise SystemExit(f'abb-sim {" ".join(argv)} exited {code}')
    return wall, json.loads(buf.getvalue())


def run(quick: bool = False, keep: str | None = None) -> None:
    res = 8 if quick else 32
    starts = res * res
    print(f'abb-sim basin, P3 (scenario p3), {res} x {res} starts of {DURATION:g} s, '
          'RK4 at 10 kHz; os.cpu_count() = %d' % (os.cpu_count() or 0))
    print(f'  before                          {load()}')
    single = one_start()
    print(f'  (a) one start in this process : {single:8.3f} s wall   projected serial '
          f'{starts * single:7.1f} s for {starts} starts   {load()}')
    tmp = tempfile.mkdtemp(prefix='bench_basin_')
    out = keep or os.path.join(tmp, 'out')
    children0 = _cpu(resource.RUSAGE_CHILDREN)
    self0 = _cpu(resource.RUSAGE_SELF)
    try:
        wall, summary = basin(res, 2, out)
    finally:
        if keep is None:
            shutil.rmtree(tmp, ignore_errors=True)
    workers = _cpu(resource.RUSAGE_CHILDREN) - children0
    own = _cpu(resource.RUSAGE_SELF) - self0
    print(f'  (b) abb-sim basin, 2 workers  : {wall:8.1f} s wall   '
          f'{starts / wall:6.2f} starts/s   {starts * single / wall:4.2f} x the projected '
          f'serial time   {load()}')
    print(f'  (c) CPU time: workers {workers:7.1f} s, this process {own:5.1f} s; '
          f'{workers / starts * 1e3:.0f} ms per start on a worker   {load()}')
    lo, hi = summary['ci95']
    print(f'      P(balance) = {summary["balanced_fraction"]:.4f} [{lo:.4f}, {hi:.4f}], '
          f'classes {summary["outcomes"]}, Floquet: {summary["floquet"]["verdict"]}')
    target = 'met' if wall < 120 else 'NOT met'
    print(f'  target: under 120 s on 2 local workers: {target} ({wall:.1f} s)')


if __name__ == '__main__':
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--quick', action='store_true', help='8 x 8 instead of 32 x 32')
    parser.add_argument('--keep', help='leave the study in this directory')
    args = parser.parse_args()
    run(args.quick, args.keep)
