"""Property-style: any float for any parameter keeps the command-line contract.

Seeded draws over each parameter's whole float range (log-uniform magnitudes 1e-320..1e308 of
either sign, and +-inf, nan, 0, -0, subnormals, 1e+-300, the largest float) for ``stability``,
``freqs``, ``map`` and ``run --duration``, in-process through ``cli.main``. Whatever the value,
the command exits 0 (a result, nothing on stderr), 1 or 2 (one stderr line, no traceback, no
warning text), in bounded time. No value is asserted.
"""

import math
import time

import numpy as np
import pytest

from abb_ros.cli import main
from abb_ros.model.parameters.params import DIMENSIONLESS_NAMES, PARAM_SPECS

SPECIAL = (math.inf, -math.inf, math.nan, 0.0, -0.0, 5e-324, 2.2250738585072014e-308 / 3,
           1e-300, -1e-300, 1e300, -1e300, 1.7976931348623157e308)
"""Values every parameter meets: the ends of the float range and the non-finite ones."""

NAMES = tuple(PARAM_SPECS) + DIMENSIONLESS_NAMES + ('omega',)
SECONDS = 20.0
"""Bound on one call: the work limits (floquet.MAX_STEPS) keep every accepted point to seconds."""


@pytest.fixture(scope='module', autouse=True)
def imported():
    from abb_ros import cli
    for name in ('stability', 'freqs', 'map', 'run'):
        cli._load(name)
    import abb_ros.app.headless  # noqa: F401
    import abb_ros.model.stability.floquet  # noqa: F401


def draws(seed, count):
    """``count`` floats over the whole range: log-uniform magnitude, random sign."""
    rng = np.random.default_rng(seed)
    magnitude = 10.0 ** rng.uniform(-320, 308, count)
    return [float(v) for v in np.where(rng.random(count) < 0.5, -magnitude, magnitude)]


def in_range(name, rng):
    """The ends of the parameter's range and a log-uniform draw inside it (none: no range)."""
    spec = PARAM_SPECS.get(name)
    if spec is None or spec.high is None or spec.type != 'double':
        return ()
    low = spec.low if spec.low and spec.low > 0 else spec.high * 1e-12
    return (spec.low, spec.high, float(10.0 ** rng.uniform(math.log10(low),
                                                           math.log10(spec.high))))


def text(value):
    return repr(value) if math.isfinite(value) else str(value)


def keeps_the_contract(capsys, argv):
    t0 = time.perf_counter()
    code = main(argv)
    elapsed = time.perf_counter() - t0
    out = capsys.readouterr()
    lines = out.err.strip().splitlines()
    assert code in (0, 1, 2), (argv, out.err)
    assert 'Traceback' not in out.err and 'Warning' not in out.err, (argv, out.err)
    assert len(lines) == (0 if code == 0 else 1), (argv, out.err)
    assert elapsed < SECONDS, (argv, elapsed)
    return code


def _argv(command, name, value):
    setting = f'{name}={text(value)}'
    if command == 'freqs':
        return ['freqs', '--set', setting]
    speed = [] if name in ('wbar', 'omega') else ['--set', 'wbar=2']
    if command == 'stability':
        return ['stability', *speed, '--set', setting]
    x, y = ('zeta', 'epsbar') if name in ('wbar', 'mbar', 'omega') else ('wbar', 'mbar')
    speed = ['--set', 'wbar=2'] if x != 'wbar' and name not in ('wbar', 'omega') else []
    return ['map', '--x', x, '--y', y, '--res', '2x2', '--no-progress', '--out', 'm.png',
            *speed, '--set', setting]


@pytest.mark.parametrize('command', ['stability', 'freqs'])
@pytest.mark.parametrize('name', ['k', 'm', 'wbar'])
def test_the_ends_of_the_float_range_keep_the_contract(capsys, command, name):
    for value in SPECIAL:
        keeps_the_contract(capsys, _argv(command, name, value))


@pytest.mark.slow
@pytest.mark.parametrize('command', ['stability', 'freqs', 'map'])
def test_any_float_for_any_parameter_keeps_the_contract(tmp_path, capsys, monkeypatch,
                                                         command):
    monkeypatch.chdir(tmp_path)
    seed = {'stability': 1, 'freqs': 2, 'map': 3}[command]
    values = draws(seed, 2 * len(NAMES))
    rng = np.random.default_rng(seed)
    for i, name in enumerate(NAMES):
        for value in (*values[2 * i:2 * i + 2], SPECIAL[rng.integers(len(SPECIAL))],
                      *in_range(name, rng)):
            if name == 'n' and math.isfinite(value):
                value = float(round(value)) if abs(value) < 1e6 else value
            keeps_the_contract(capsys, _argv(command, name, value))


@pytest.mark.parametrize('seed', [0, pytest.param(1, marks=pytest.mark.slow)])
def test_any_run_duration_keeps_the_contract(tmp_path, capsys, monkeypatch, seed):
    """Durations that are accepted and long are checked, not run (they run for hours)."""
    from abb_ros.app.headless import check_duration
    from abb_ros.model.parameters.params import ParamError
    monkeypatch.chdir(tmp_path)
    for value in (*SPECIAL, *draws(seed + 10, 24)):
        if 0.05 < value <= 1e4:
            check_duration(value)
            continue
        if 0.001 <= value <= 0.05:
            assert keeps_the_contract(capsys, ['run', '--duration', text(value),
                                               '--no-progress']) == 0
            continue
        code = keeps_the_contract(capsys, ['run', '--duration', text(value), '--no-progress'])
        assert code == 2
        with pytest.raises(ParamError):
            check_duration(value)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
@pytest.mark.parametrize('argv', [
    ['stability', '--set', 'omega=5e-324'], ['freqs', '--set', 'k=nan'],
    ['map', '--x', 'wbar', '--y', 'mbar', '--range-x', '0.2:1e300', '--out', 'm.png'],
    ['run', '--duration', '1e300']])
def test_the_console_script_keeps_the_contract(tmp_path, argv):
    """The installed entry point, a fresh process: no warning text from any import either."""
    import os
    import subprocess
    import sys
    abb_sim = os.path.join(os.path.dirname(sys.executable), 'abb-sim')
    t0 = time.perf_counter()
    proc = subprocess.run([abb_sim, *argv], capture_output=True, text=True, timeout=120,
                          cwd=tmp_path, stdin=subprocess.DEVNULL)
    assert time.perf_counter() - t0 < 60
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and proc.stdout == ''
    assert 'Warning' not in proc.stderr and 'Traceback' not in proc.stderr
    assert list(tmp_path.iterdir()) == []
