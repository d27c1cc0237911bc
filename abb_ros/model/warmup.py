"""Compile the numba kernels into numba's on-disk cache: by kernel set, in parallel processes.

``python -m abb_ros.model.warmup [--sets simulator,floquet] [--jobs 2]`` (run by
scripts/ensure-venv; colcon users run ``ros2 run abb_ros warmup`` once after ``colcon build``,
see docs/time_under_load.md). numba (``cache=True``) keeps the machine code in ``__pycache__``
next to the sources (``*.nbi``/``*.nbc``); where that directory is not writable (a read-only
install) numba uses its user-wide cache, ``$NUMBA_CACHE_DIR`` if set, else ``~/.cache/numba``
(``$XDG_CACHE_HOME/numba``). A kernel not compiled here compiles on its first call (and is
cached then), so nothing needs all of them: the simulator on the paper's path needs the
``simulator`` set only (about 15 s to compile on this machine, against minutes for all).

Kernel sets (:data:`KERNEL_SETS`): ``simulator`` (the paper's stepping, Eqs. 18-24, q'', the
IMU and the speed sensor: a node's first message), ``general`` (the stepping with contact,
rolling resistance or a torque-driven spindle, trajectories and the IMU of the headless run),
``adaptive`` (Dormand-Prince), ``floquet`` (the analysis node's speed bands), ``sweep`` (the
batch kernels of sweeps and maps). Each set compiles in its own process (``--jobs`` at a time).

Staleness: numba checks a cached kernel against the time stamp of its own source file only, so
a kernel that calls into a changed module (``kernels/stepper.py`` into ``kernels/contact.py``)
would load stale machine code. Before compiling, :func:`refresh_stale` gives every compiled
entry point a key, the SHA-256 of the source files its module imports from ``abb_ros``
(transitively) and of numba's version, and deletes the cached machine code of exactly those
entry points whose key changed: editing one physics module recompiles what depends on it.
"""

from __future__ import annotations

import argparse
import ast
import hashlib
import inspect
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from abb_ros.model.dynamics.integrate import DEFAULT_DT, Simulation
from abb_ros.model.dynamics.spindle import SpindleMotor, TorqueMotor
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.sensors import imu
from abb_ros.model.sensors.imu import TYPICAL_IMU, ImuModel
from abb_ros.model.sensors.speed_sensor import SpeedSensor

WARMUP_TABLE_POINTS = 4
"""Speeds of the warm-up table: the kernels' types do not depend on the count."""

PACKAGE_ROOT = Path(__file__).resolve().parents[1]
"""The ``abb_ros`` package directory (module closures stay inside it)."""


def _drive():
    params = DriveParams()
    return params, 2.7 * params.omega0


def warm_simulator() -> None:
    """Compile the paper's path of a node: paper stepping, q'', the IMU, the speed sensor."""
    params, omega = _drive()
    sim = Simulation(params, omega, DEFAULT_DT, spindle=SpindleMotor(2000.0, 0.05))
    sim.advance(1)
    qdd = np.empty(sim.N)
    sim.advance_accelerations(1, qdd)
    sim.accelerations()
    s = sim.layout
    ImuModel(TYPICAL_IMU).read(sim.y[s.q], sim.y[s.qd], qdd)
    ImuModel(TYPICAL_IMU).read_with_pose(sim.y, params.n_balls, qdd, np.empty(sim.y.size + 19))
    imu.JIT.deck_pose_twist(sim.y, params.n_balls, np.empty(13))
    fg = SpeedSensor()
    for step in range(2):
        fg.update(step * 1e-3, step * 1e-3 * omega, omega)


def warm_general() -> None:
    """Compile the path off the paper's (a torque-driven spindle): stepping, trajectories, IMU."""
    params, omega = _drive()
    sim = Simulation(params, omega, DEFAULT_DT, spindle=TorqueMotor())
    sim.advance(1)
    sim.advance_accelerations(1, np.empty(sim.N))
    sim.trajectory(2, 1)
    ys = np.array([sim.y, sim.y])                      # the headless run's periods in batches
    ImuModel(TYPICAL_IMU).read_many(ys, sim.accelerations_along(ys, [1, 2]), params.n_balls)


def warm_adaptive() -> None:
    """Compile the adaptive Dormand-Prince 5(4) integrator."""
    params, omega = _drive()
    Simulation(params, omega, DEFAULT_DT, integrator='adaptive').trajectory(2, 1)


def warm_floquet() -> None:
    """Compile the analysis node's speed bands (monodromy matrices, Floquet multipliers)."""
    from abb_ros.model.stability import speed_bands
    params, omega = _drive()
    table = speed_bands.speed_table(params, 1500.0, WARMUP_TABLE_POINTS)
    speed_bands.refine(table, omega)


def warm_sweep() -> None:
    """Compile the batch kernels of sweeps and maps (Floquet batch, batch RK4)."""
    from abb_ros.model.dynamics import batch
    from abb_ros.model.stability import floquet
    params, omega = _drive()
    floquet.max_multiplier_batch([params], [omega], 'in', kern=floquet.SERIAL)
    sim = Simulation(params, omega, DEFAULT_DT, spindle=SpindleMotor(2000.0, 0.05))
    run = batch.BatchRun([params], sim.y[None, :].copy(), sim.spindle.pack(omega)[None, :],
                         DEFAULT_DT, 1e-3)
    run.advance(1)


KERNEL_SETS = {'simulator': warm_simulator, 'general': warm_general,
               'adaptive': warm_adaptive, 'floquet': warm_floquet, 'sweep': warm_sweep}
"""Name -> a function that calls each kernel of the set once on the Table 1 drive."""


def warm_up(sets=None) -> dict[str, float]:
    """Compile (or load) the kernel sets ``sets`` (default all) in this process; {set: s}."""
    took = {}
    for name in sets or KERNEL_SETS:
        start = time.perf_counter()
        KERNEL_SETS[name]()
        took[name] = time.perf_counter() - start
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
    paths = []
    for _, source in entry_points():
        where = str(kernel_cache_dir(source))
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


def compiled_namespaces() -> list:
    """Return the compiled kernel namespaces of ``abb_ros.model`` (empty when numba is off)."""
    from abb_ros.model.dynamics import batch, kernels
    from abb_ros.model.sensors import speed_sensor
    from abb_ros.model.stability import monodromy
    spaces = [kernels.JIT, batch.JIT, imu.JIT, speed_sensor.JIT, monodromy.JIT]
    return [k for k in spaces if k.compiled]


def entry_points() -> list[tuple[str, Path]]:
    """(cache file prefix ``<module>.<kernel>``, source file) of every compiled entry point."""
    found = []
    for space in compiled_namespaces():
        for name in space.names:
            source = Path(inspect.getfile(getattr(space, name).py_func)).resolve()
            found.append((f'{source.stem}.{name}', source))
    return found


def module_closure(source: Path) -> list[Path]:
    """``source`` and the ``abb_ros`` modules it imports, transitively (sorted)."""
    seen = set()
    todo = [source.resolve()]
    while todo:
        path = todo.pop()
        if path in seen or not path.is_file():
            continue
        seen.add(path)
        for node in ast.walk(ast.parse(path.read_bytes(), str(path))):
            names = []
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module] + [f'{node.module}.{a.name}' for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            for dotted in names:
                if dotted.split('.')[0] != PACKAGE_ROOT.name:
                    continue
                base = PACKAGE_ROOT.parent.joinpath(*dotted.split('.'))
                for candidate in (base.with_suffix('.py'), base / '__init__.py'):
                    if candidate.is_file():
                        todo.append(candidate.resolve())
    return sorted(seen)


def entry_key(source: Path) -> str:
    """SHA-256 of the module closure of ``source`` and of numba's version."""
    import numba
    digest = hashlib.sha256(numba.__version__.encode())
    for path in module_closure(source):
        digest.update(str(path.relative_to(PACKAGE_ROOT.parent)).encode() + b'\0')
        digest.update(path.read_bytes())
    return digest.hexdigest()


KEY_SUFFIX = '.abbkey'
"""The file beside an entry point's cached machine code that holds its :func:`entry_key`."""


def refresh_stale() -> int:
    """Delete the cached machine code of every entry point whose key changed; return how many.

    The new keys are written (an entry point without cached code gets its key too: it compiles
    from the sources that key was computed from). Entry points whose key is unchanged keep
    their cache.
    """
    keys = {}
    stale = 0
    for prefix, source in entry_points():
        if source not in keys:
            keys[source] = entry_key(source)
        where = kernel_cache_dir(source)
        stamp = where / (prefix + KEY_SUFFIX)
        try:
            current = stamp.read_text()
        except OSError:
            current = None
        if current == keys[source]:
            continue
        cached = list(where.glob(prefix + '-*.nbi')) + list(where.glob(prefix + '-*.nbc'))
        for path in cached:
            path.unlink(missing_ok=True)
        stale += bool(cached)
        where.mkdir(parents=True, exist_ok=True)
        stamp.write_text(keys[source])
    return stale


LANES = (('general', 'sweep'), ('simulator', 'floquet', 'adaptive'))
"""Sets that share compiled callees go in one process: numba caches entry points only, so a
callee compiled into two entry points in two processes is compiled twice (``sweep`` alone in a
process of its own took 168 s against 7 s after ``general``)."""


def lanes_of(sets, jobs: int) -> list[list[str]]:
    """Split ``sets`` into at most ``jobs`` processes' worth, keeping :data:`LANES` together."""
    lanes = [[name for name in lane if name in sets] for lane in LANES]
    lanes = [lane for lane in lanes if lane]
    while len(lanes) > max(1, jobs):
        last = lanes.pop()
        lanes[-1].extend(last)
    return lanes


def compile_in_processes(sets, jobs: int, report=print) -> dict[str, float]:
    """Compile the kernel sets in :func:`lanes_of` processes at once; {set: s in its process}.

    ``report`` gets one line per set as it ends. Raises RuntimeError naming the sets whose
    process failed (its output included).
    """
    def lane(names):
        # -P and PYTHONPATH: the lane imports this very package (an install tree's), never
        # one that happens to sit in the working directory.
        path = os.pathsep.join(filter(None, [str(PACKAGE_ROOT.parent),
                                             os.environ.get('PYTHONPATH')]))
        done = subprocess.run([sys.executable, '-P', '-m', 'abb_ros.model.warmup',
                               '--in-process', '--sets', ','.join(names)],
                              capture_output=True, text=True,
                              env=dict(os.environ, PYTHONPATH=path))
        if done.returncode != 0:
            raise RuntimeError(f'compiling the {",".join(names)} kernels failed:\n'
                               f'{done.stdout}{done.stderr}')
        return {name: float(seconds) for name, seconds in
                (line.split() for line in done.stdout.splitlines() if line.strip())}

    took = {}
    with ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        futures = [pool.submit(lane, names) for names in lanes_of(sets, jobs)]
        for future in as_completed(futures):
            for name, seconds in future.result().items():
                took[name] = seconds
                report(f'abb_ros: {name} kernels compiled or loaded in {seconds:.1f} s '
                       f'({len(took)}/{len(sets)})')
    return {name: took[name] for name in sets}


def parse_sets(text: str | None) -> list[str]:
    """Return the kernel sets named in ``text`` (comma-separated; None: all); ValueError."""
    if text is None:
        return list(KERNEL_SETS)
    sets = [t.strip() for t in text.split(',') if t.strip()]
    unknown = [t for t in sets if t not in KERNEL_SETS]
    if unknown or not sets:
        raise ValueError(f'--sets: {",".join(unknown) or "(empty)"} is not a kernel set; '
                         f'valid: {", ".join(KERNEL_SETS)} (comma-separated)')
    return sets


def main(argv=None) -> int:
    """Refresh stale kernels, compile the sets asked for; print the times; return 0 (2: usage)."""
    ap = argparse.ArgumentParser(prog='warmup', description=__doc__.split('\n\n')[0])
    ap.add_argument('--sets', help=f'comma-separated kernel sets [all: {",".join(KERNEL_SETS)}]')
    ap.add_argument('--jobs', type=int, default=min(os.cpu_count() or 1, len(KERNEL_SETS)),
                    help='sets compiled at a time, each in its own process [CPUs]')
    ap.add_argument('--clear', action='store_true',
                    help='delete every cached kernel first (not only the stale ones)')
    ap.add_argument('--in-process', action='store_true', help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    try:
        sets = parse_sets(args.sets)
    except ValueError as err:
        print(f'warmup: {err}', file=sys.stderr)
        return 2
    if args.jobs < 1:
        print(f'warmup: --jobs: {args.jobs} is not valid; valid: an integer >= 1',
              file=sys.stderr)
        return 2
    if args.in_process:                 # a lane of compile_in_processes: "set seconds" lines
        for name, seconds in warm_up(sets).items():
            print(name, seconds, flush=True)
        return 0
    if not compiled_namespaces():
        print('abb_ros: numba disabled (ABB_ROS_NO_JIT): nothing to compile')
        return 0
    removed = clear_cache() if args.clear else 0
    stale = refresh_stale()
    if removed or stale:
        print(f'abb_ros: {removed} cached kernel files deleted, {stale} stale kernels '
              'to recompile')
    start = time.perf_counter()
    try:
        took = compile_in_processes(sets, args.jobs)
    except RuntimeError as err:
        print(f'abb_ros: {err}', file=sys.stderr)
        return 1
    parts = ', '.join(f'{k} {v:.1f} s' for k, v in took.items())
    locations = cache_locations()
    if len(locations) > 1:
        print('abb_ros: numba keeps the kernels in ' + ' and '.join(locations))
    print(f'abb_ros kernels compiled or loaded in {time.perf_counter() - start:.1f} s wall '
          f'({parts}; {args.jobs} at a time); cache: {cache_location()}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
