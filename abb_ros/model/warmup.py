"""Compile every numba kernel the nodes and the CLI use, once, into numba's on-disk cache.

``python -m abb_ros.model.warmup`` (run by scripts/ensure-venv; colcon users run it once after
``colcon build``, see docs/time_under_load.md). numba (``cache=True``) keeps the machine code
in ``__pycache__`` next to the sources (``*.nbi``/``*.nbc``); where that directory is not
writable (a read-only install) numba uses its user-wide cache, ``$NUMBA_CACHE_DIR`` if set,
else ``~/.cache/numba`` (``$XDG_CACHE_HOME/numba``). Without this step the first start of the
simulator (integration kernels) and of the analysis node (Floquet kernels) compiles them.

It first deletes the package's cached kernels: numba checks a cached function against the
time stamp of its own source file only, so a kernel that calls into a changed module (e.g.
``batch.py`` or ``kernels/stepper.py`` calling into ``kernels/contact.py``) would load stale
machine code. Run it after every change
or update of ``abb_ros/model`` (scripts/ensure-venv does).
"""

from __future__ import annotations

import hashlib
import inspect
import os
import sys
import time
from pathlib import Path

import numpy as np

from abb_ros.model.dynamics.integrate import DEFAULT_DT, Simulation
from abb_ros.model.dynamics.spindle import SpindleMotor
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.sensors import imu
from abb_ros.model.sensors.imu import TYPICAL_IMU, ImuModel
from abb_ros.model.sensors.speed_sensor import SpeedSensor
from abb_ros.model.stability import speed_bands

WARMUP_TABLE_POINTS = 4
"""Speeds of the warm-up table: the kernels' types do not depend on the count."""


def warm_up() -> dict[str, float]:
    """Run each kernel once on the Table 1 drive (small sizes); {part: seconds}."""
    params = DriveParams()
    omega = 2.7 * params.omega0
    took = {}
    start = time.perf_counter()
    sim = Simulation(params, omega, DEFAULT_DT, spindle=SpindleMotor(2000.0, 0.05))
    sim.advance(1)
    sim.accelerations()
    sim.trajectory(2, 1)
    s = sim.layout
    ImuModel(TYPICAL_IMU).read(sim.y[s.q], sim.y[s.qd], sim.accelerations())
    qdd = np.empty(sim.N)
    sim.advance_accelerations(1, qdd)
    ImuModel(TYPICAL_IMU).read_with_pose(sim.y, params.n, qdd, np.empty(sim.y.size + 19))
    imu.JIT.deck_pose_twist(sim.y, params.n, np.empty(13))
    ys = np.array([sim.y, sim.y])                      # the headless run's periods in batches
    ImuModel(TYPICAL_IMU).read_many(ys, sim.accelerations_along(ys, [1, 2]), params.n)
    fg = SpeedSensor()
    for step in range(2):
        fg.update(step * 1e-3, step * 1e-3 * omega, omega)
    Simulation(params, omega, DEFAULT_DT, integrator='adaptive').trajectory(2, 1)
    took['integration'] = time.perf_counter() - start
    start = time.perf_counter()
    table = speed_bands.speed_table(params, 1500.0, WARMUP_TABLE_POINTS)
    speed_bands.refine(table, omega)
    took['floquet'] = time.perf_counter() - start
    start = time.perf_counter()
    from abb_ros.model.dynamics import batch
    from abb_ros.model.stability import floquet
    floquet.max_multiplier_batch([params], [omega], 'in', kern=floquet.SERIAL)
    run = batch.BatchRun([params], sim.y[None, :].copy(), sim.spindle.pack(omega)[None, :],
                         DEFAULT_DT, 1e-3)
    run.advance(1)
    took['sweep'] = time.perf_counter() - start
    return took


def kernel_cache_dir(source: str | os.PathLike) -> Path:
    """Return the directory numba (``cache=True``) keeps the kernels of the file ``source`` in.

    numba's order of places: ``$NUMBA_CACHE_DIR`` (``numba.config.CACHE_DIR``) when set, else
    ``__pycache__`` beside the source when it is writable, else the user-wide cache
    (``$XDG_CACHE_HOME/numba``, default ``~/.cache/numba``). In the first and last, numba keeps
    each source directory apart in a sub-directory named after it and the SHA-1 of its absolute
    path. Computed from the source's path, without reading numba's private state; a test checks
    the answer against the files numba writes.
    """
    import numba
    folder = os.path.dirname(os.path.abspath(source))
    sub = os.path.basename(folder) + '_' + hashlib.sha1(folder.encode()).hexdigest()
    if numba.config.CACHE_DIR:
        return Path(numba.config.CACHE_DIR) / sub
    in_tree = Path(folder) / '__pycache__'
    if os.access(in_tree if in_tree.is_dir() else folder, os.W_OK):
        return in_tree
    user = os.environ.get('XDG_CACHE_HOME') or os.path.join(os.path.expanduser('~'), '.cache')
    return Path(user) / 'numba' / sub


def cache_locations() -> list[str]:
    """Return the directories numba caches this package's kernels in (none without numba).

    One per source directory that holds kernels: the dynamics' kernels package, the dynamics
    (batch), the sensors and the stability analysis (the monodromy kernels).
    """
    from abb_ros.model.dynamics import batch, kernels
    from abb_ros.model.stability import monodromy
    paths = []
    for kern, entry in ((kernels.JIT, 'advance'), (batch.JIT, 'rk4_metrics_batch'),
                        (imu.JIT, 'deck_pose_twist'), (monodromy.JIT, 'monodromy_many_serial')):
        if not kern.compiled:
            return []
        where = str(kernel_cache_dir(inspect.getfile(getattr(kern, entry).py_func)))
        if where not in paths:
            paths.append(where)
    return paths


def cache_location() -> str:
    """Return the directory numba caches the integration kernels in (the first location)."""
    locations = cache_locations()
    return locations[0] if locations else 'none (numba disabled: ABB_ROS_NO_JIT)'


def clear_cache() -> int:
    """Delete this package's cached kernels; return how many files were deleted.

    The index and data files in :func:`cache_locations` (every file there is one of
    abb_ros.model's).
    """
    removed = 0
    for where in map(Path, cache_locations()):
        if not where.is_dir():
            continue
        for path in list(where.glob('*.nbi')) + list(where.glob('*.nbc')):
            try:
                path.unlink()
                removed += 1
            except FileNotFoundError:
                pass
    return removed


def main() -> int:
    """Clear the cache, compile every kernel, print the times; return 0."""
    removed = clear_cache()
    if removed:
        print(f'abb_ros: {removed} cached kernel files deleted (recompiling)')
    took = warm_up()
    parts = ', '.join(f'{k} {v:.1f} s' for k, v in took.items())
    locations = cache_locations()
    if len(locations) > 1:
        print('abb_ros: numba keeps the kernels in ' + ' and '.join(locations))
    print(f'abb_ros kernels compiled or loaded ({parts}); cache: {cache_location()}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
