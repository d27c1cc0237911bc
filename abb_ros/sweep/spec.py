"""Sweep specifications (``abb-sim sweep SPEC.yaml``): which drives to draw and what to compute.

A spec is a YAML mapping (docs/sweep.md has the full reference)::

    name: tolerance_p3
    description: ...
    scenario: p3            # nominal drive, initial state and speed profile (name or file)
    base: {c: 0.66}         # settings on top of the scenario's drive (SI or Eq. 39 names)
    parameters:             # what varies from drive to drive
      eps: {dist: normal, mean: 0.25e-3, std: 0.025e-3, low: 0.15e-3, high: 0.35e-3}
      k:   {dist: uniform, low: 3575, high: 4369}
      n:   {dist: list, values: [2, 3]}
      D:   {dist: grid, low: 2.0e-6, high: 8.0e-6, points: 4}
    samples: 10000          # draws per grid point (1..MAX_SAMPLES in all)
    sampling: {method: sobol, seed: 1}        # random | lhs | sobol
    partition_size: 500     # samples per task (one Parquet file each)
    operating_wbar: 2.7     # default: the scenario's last commanded speed
    compute:
      stability: {wbar: [2.7]}    # or omega: [...], or range: {wbar: [lo, hi], points: k}
      run: {duration: 1.0, rbar_limit: 1.0e-3}   # integrator: rk4 (default) | adaptive

Speeds given as wbar are converted with the *nominal* drive's omega0 (scenario + base), so
every drive of the batch turns at the same physical speed, as the drives of a production lot
do; a drive whose washers are stiffer runs at a lower wbar of its own.

All samples are drawn up front from the seed (:func:`abb_ros.sweep.sampling.draw_samples`),
before they are cut into partitions, so the samples and the results do not depend on how the
work is partitioned or where it runs. Errors are
:class:`~abb_ros.model.parameters.params.ParamError` naming the field (``parameters.k.low``,
``compute.run.duration``, ...) and what is valid.
"""

from __future__ import annotations

import copy
import math
import os
from dataclasses import dataclass

import numpy as np

from abb_ros.io.files import fields
from abb_ros.io.files.safe_yaml import YamlFileError, load_file
from abb_ros.model.parameters.drive_spec import MAX_OMEGA
from abb_ros.model.parameters.param_spec import ParamError
from abb_ros.model.parameters.params import DIMENSIONLESS_NAMES, PARAM_SPECS, apply_settings
from abb_ros.sweep.starts import START_PARAMETERS, check_start_value, check_starts, is_start

__all__ = ['MAX_SAMPLES', 'MAX_SPEC_BYTES', 'MAX_SPEEDS', 'SweepSpec', 'load_spec', 'parse_spec',
           'SAMPLEABLE', 'DISTRIBUTIONS', 'METHODS']

MAX_SAMPLES = 1_000_000
"""Largest number of drives in one sweep (grid points times samples)."""

MAX_PARTITION = 100_000
"""Largest partition (samples per task and per Parquet file)."""

MAX_SPEEDS = 1000
"""Most speeds in ``compute.stability``."""

MAX_SPEC_BYTES = 1 << 20
"""Largest spec file accepted (1 MiB)."""

MAX_DURATION = 1000.0
"""Longest run in ``compute.run.duration`` [s]."""

_DRIVE = tuple(PARAM_SPECS) + tuple(n for n in DIMENSIONLESS_NAMES if n != 'wbar')
SAMPLEABLE = _DRIVE + START_PARAMETERS
"""Parameters a spec may vary: the SI drive parameters and the Eq. (39) names but wbar (speeds
belong to ``compute``), and the start of the runs (:mod:`abb_ros.sweep.starts`)."""

_SAME_FIELD = {'mbar': 'm', 'epsbar': 'eps', 'zeta': 'c', 'Dbar': 'D'}
"""Eq. (39) names and the SI field each sets: a spec may vary one of the two."""

DISTRIBUTIONS = {
    'uniform': ({'low', 'high'}, set()),
    'normal': ({'mean', 'std', 'low', 'high'}, set()),
    'list': ({'values'}, set()),
    'grid': (set(), {'values', 'low', 'high', 'points'}),
}
"""Keys (required, optional) of each distribution besides ``dist``."""

METHODS = ('random', 'lhs', 'sobol')
_TOP_KEYS = {'name', 'description', 'scenario', 'base', 'parameters', 'samples', 'sampling',
             'partition_size', 'operating_wbar', 'operating_omega', 'compute'}
_SAMPLING_KEYS = {'method', 'seed'}
_COMPUTE_KEYS = {'stability', 'run'}
_STABILITY_KEYS = {'wbar', 'omega', 'range'}
_RANGE_KEYS = {'wbar', 'omega', 'points'}
_RUN_KEYS = {'duration', 'rbar_limit', 'dt', 'integrator'}
DEFAULT_PARTITION = 256
DEFAULT_RBAR_LIMIT = 1.0e-3


# ---- YAML ------------------------------------------------------------------------------------

def load_yaml(path) -> object:
    """Read the YAML document at ``path`` with the package's one loader.

    That is abb_ros/io/files/safe_yaml.py: size-capped at MAX_SPEC_BYTES, no aliases, nesting
    capped; a ParamError naming 'spec' otherwise.
    """
    try:
        return load_file(path, max_bytes=MAX_SPEC_BYTES)
    except YamlFileError as exc:
        raise ParamError('spec', str(path), f'a readable YAML file of at most {MAX_SPEC_BYTES} '
                         'bytes, without aliases (*name)', exc.why) from None


# ---- checks ------------------------------------------------------------------------------

def _int(where, value, low, high):
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ParamError(where, value, f'an integer in [{low}, {high}]')
    return int(value)


def _str(where, value):
    if not isinstance(value, str):
        raise ParamError(where, value, 'a string')
    return value


# ---- the spec ----------------------------------------------------------------------------

@dataclass
class SweepSpec:
    """A validated sweep spec. ``doc`` is the normalised mapping (stored with the results)."""

    doc: dict
    name: str
    scenario: object           # abb_ros.io.files.scenario.Scenario (nominal drive, base applied)
    base: dict
    parameters: dict           # name -> normalised distribution mapping
    samples: int               # draws per grid point
    method: str
    seed: int
    partition_size: int
    operating_omega: float     # [rad/s]
    speeds: np.ndarray | None  # stability speeds [rad/s] (operating speed included), or None
    run: dict | None           # {'duration', 'rbar_limit', 'dt', 'integrator'} or None

    @property
    def grid(self) -> dict:
        """Grid parameters and their values, {name: [values]}."""
        return {k: v['values'] for k, v in self.parameters.items() if v['dist'] == 'grid'}

    @property
    def drawn(self) -> list:
        """Names of the parameters drawn at random (not on the grid)."""
        return [k for k, v in self.parameters.items() if v['dist'] != 'grid']

    @property
    def total(self) -> int:
        """Number of drives: samples times the grid points."""
        return self.samples * math.prod(len(v) for v in self.grid.values())

    @property
    def partitions(self) -> int:
        """Number of partitions (Parquet files) of the sweep."""
        return -(-self.total // self.partition_size)

    def partition_bounds(self, i: int) -> tuple[int, int]:
        """Return the [start, stop) point indices of partition ``i``."""
        start = i * self.partition_size
        return start, min(start + self.partition_size, self.total)


def load_spec(path) -> SweepSpec:
    """Read and validate a spec file."""
    doc = load_yaml(path)
    return parse_spec(doc, base_dir=os.path.dirname(os.path.abspath(str(path))))


def parse_spec(doc, base_dir=None) -> SweepSpec:
    """Validate a spec mapping (as loaded from YAML) and normalise it."""
    fields.mapping('', doc, _TOP_KEYS, required=('parameters', 'compute'))
    doc = copy.deepcopy(doc)
    name = _str('name', doc.get('name', 'sweep'))
    description = _str('description', doc.get('description', ''))
    scen_name, scenario, base = _scenario(doc, base_dir)
    nominal = scenario.params
    parameters = _parameters(doc['parameters'], nominal)
    sampling = fields.mapping('sampling', doc.get('sampling') or {}, _SAMPLING_KEYS)
    method = sampling.get('method', 'random')
    if method not in METHODS:
        raise ParamError('sampling.method', method, 'one of ' + ', '.join(METHODS))
    seed = _int('sampling.seed', sampling.get('seed', 0), 0, 2 ** 63 - 1)
    samples = _samples(doc, parameters)
    partition_size = _int('partition_size', doc.get('partition_size', DEFAULT_PARTITION), 1,
                          MAX_PARTITION)
    operating = _operating(doc, scenario)
    compute = fields.mapping('compute', doc['compute'], _COMPUTE_KEYS)
    if not compute:
        raise ParamError('compute', compute, 'at least one of stability, run')
    speeds = None
    if 'stability' in compute:
        speeds = _speeds(compute['stability'] or {}, nominal.omega0, operating)
    run = _run(compute['run'], scenario) if 'run' in compute else None
    check_starts(parameters, parameters.get('n', {'values': [nominal.n]})['values'], run)
    doc.update(name=name, description=description, scenario=scen_name, base=base,
               parameters=parameters, samples=samples,
               sampling={'method': method, 'seed': seed}, partition_size=partition_size)
    return SweepSpec(doc, name, scenario, base, parameters, samples, method, seed,
                     partition_size, float(operating), speeds, run)


def _scenario(doc, base_dir):
    """Return (its name, the scenario with ``base`` applied, ``base``) of a spec."""
    from abb_ros.io.files.scenario import load_scenario
    scen_name = _str('scenario', doc.get('scenario', 'p3'))
    if base_dir and (scen_name.endswith(('.yaml', '.yml')) or os.sep in scen_name) \
            and not os.path.isabs(scen_name):
        scen_path = os.path.join(base_dir, scen_name)
    else:
        scen_path = scen_name
    scenario = load_scenario(scen_path)
    base = doc.get('base') or {}
    if not isinstance(base, dict):
        raise ParamError('base', base, 'a mapping name: value of SI or Eq. (39) names')
    for key, value in base.items():
        if key not in _DRIVE:
            raise ParamError(f'base.{key}', value, 'one of ' + ', '.join(_DRIVE),
                             'unknown parameter')
    return scen_name, scenario.with_settings(base), base


def _parameters(params_doc, nominal) -> dict:
    """Return {name: checked distribution} of the spec's ``parameters``."""
    if not isinstance(params_doc, dict) or not params_doc:
        raise ParamError('parameters', params_doc,
                         'a non-empty mapping name: {dist: ...} with names from '
                         + ', '.join(SAMPLEABLE))
    parameters = {}
    for pname, dist in params_doc.items():
        if pname not in SAMPLEABLE:
            raise ParamError(f'parameters.{pname}', dist, 'one of ' + ', '.join(SAMPLEABLE),
                             'unknown parameter')
        twin = _SAME_FIELD.get(pname) or {v: k for k, v in _SAME_FIELD.items()}.get(pname)
        if twin in params_doc:
            raise ParamError(f'parameters.{pname}', dist, f'one of {pname} and {twin}, not '
                             'both', f'both set {_SAME_FIELD.get(pname, pname)}')
        parameters[pname] = _distribution(f'parameters.{pname}', pname, dist, nominal)
    return parameters


def _samples(doc, parameters) -> int:
    """Return the draws per grid point: ``samples``, 1 when every parameter is a grid."""
    has_drawn = any(v['dist'] != 'grid' for v in parameters.values())
    if 'samples' in doc:
        samples = _int('samples', doc['samples'], 1, MAX_SAMPLES)
    elif has_drawn:
        raise ParamError('samples', None, f'an integer in [1, {MAX_SAMPLES}]', 'missing')
    else:
        samples = 1
    if not has_drawn and samples != 1:
        raise ParamError('samples', samples, '1 when every parameter is a grid')
    grid_points = math.prod(len(v['values']) for v in parameters.values()
                            if v['dist'] == 'grid')
    if samples * grid_points > MAX_SAMPLES:
        raise ParamError('samples', samples, f'at most {MAX_SAMPLES} drives in all '
                         f'(samples x {grid_points} grid points)')
    return samples


def _operating(doc, scenario) -> float:
    """Return the operating speed [rad/s]: given as wbar or omega, else the scenario's last."""
    if 'operating_wbar' in doc and 'operating_omega' in doc:
        raise ParamError('operating_omega', doc['operating_omega'],
                         'absent when operating_wbar is given (one of the two)')
    if 'operating_wbar' in doc:
        return _speed('operating_wbar', doc['operating_wbar'], scenario.params.omega0)
    if 'operating_omega' in doc:
        return _speed('operating_omega', doc['operating_omega'], 1.0)
    operating = scenario.commands[-1].omega if scenario.commands else scenario.omega
    if operating <= 0:
        raise ParamError('operating_wbar', None, '(0, inf): the scenario stops the spindle')
    return operating


def _run(run_doc, scenario) -> dict:
    """Return the checked ``compute.run``: duration, rbar_limit, dt."""
    r = fields.mapping('compute.run', run_doc or {}, _RUN_KEYS)
    number = fields.finite_number
    run = {'duration': number('compute.run.duration', r.get('duration', scenario.duration),
                              0.0, True, MAX_DURATION),
           'rbar_limit': number('compute.run.rbar_limit',
                                r.get('rbar_limit', DEFAULT_RBAR_LIMIT), 0.0, True),
           'dt': number('compute.run.dt', r.get('dt', 1e-4), 0.0, True, 1e-2),
           'integrator': _integrator(r.get('integrator', 'rk4'))}
    _check_run_steps(run)
    return run


def _check_run_steps(run: dict) -> None:
    """Refuse a run of more steps than ``abb-sim run`` takes (MAX_RUN_STEPS), before any work.

    ``compute.run.dt: 1e-12`` would otherwise integrate 1e12 steps per drive, for days.
    """
    from abb_ros.model.dynamics.integrate import MAX_RUN_STEPS
    steps = run['duration'] / run['dt']
    if steps > MAX_RUN_STEPS:
        raise ParamError('compute.run.dt', run['dt'],
                         f"[{run['duration'] / MAX_RUN_STEPS:g}, 0.01] s for a duration of "
                         f"{run['duration']:g} s",
                         f'{steps:.3g} steps per drive; at most {MAX_RUN_STEPS} steps per run, '
                         'as abb-sim run')


def _speeds(st, omega0, operating):
    """Stability speeds [rad/s], sorted, the operating speed included."""
    st = fields.mapping('compute.stability', st, _STABILITY_KEYS)
    given = [k for k in _STABILITY_KEYS if k in st]
    if len(given) > 1:
        raise ParamError(f'compute.stability.{sorted(given)[1]}', st[sorted(given)[1]],
                         'one of wbar, omega, range (not several)')
    values = []
    if 'wbar' in st or 'omega' in st:
        key = 'wbar' if 'wbar' in st else 'omega'
        lst = st[key]
        if not isinstance(lst, list) or not 1 <= len(lst) <= MAX_SPEEDS:
            raise ParamError(f'compute.stability.{key}', lst,
                             f'a list of 1..{MAX_SPEEDS} positive speeds')
        scale = omega0 if key == 'wbar' else 1.0
        values = [_speed(f'compute.stability.{key}', v, scale) for v in lst]
    elif 'range' in st:
        rng = fields.mapping('compute.stability.range', st['range'], _RANGE_KEYS,
                             required=('points',))
        keys = [k for k in ('wbar', 'omega') if k in rng]
        if len(keys) != 1:
            raise ParamError('compute.stability.range', rng, 'exactly one of wbar: [lo, hi] or '
                             'omega: [lo, hi], and points')
        key = keys[0]
        lohi = rng[key]
        if not isinstance(lohi, list) or len(lohi) != 2:
            raise ParamError(f'compute.stability.range.{key}', lohi, 'a list [low, high]')
        scale = omega0 if key == 'wbar' else 1.0
        lo = _speed(f'compute.stability.range.{key}', lohi[0], scale) / scale
        hi = _speed(f'compute.stability.range.{key}', lohi[1], scale) / scale
        if not hi > lo:
            raise ParamError(f'compute.stability.range.{key}', lohi,
                             'a non-empty range [low, high] with low < high')
        points = _int('compute.stability.range.points', rng['points'], 2, MAX_SPEEDS)
        scale = omega0 if key == 'wbar' else 1.0
        values = list(np.linspace(lo, hi, points) * scale)
    # the operating speed replaces a listed speed within round-off of it (linspace end points)
    values = [v for v in values if abs(v - operating) > 1e-9 * operating] + [operating]
    return np.unique(np.asarray(values, dtype=float))


def _speed(where, value, scale):
    """Return the speed [rad/s] of ``value`` (wbar: ``scale`` omega0, omega: 1), checked."""
    unit = 'rad/s' if scale == 1.0 else f'(omega0 = {scale:.6g} rad/s)'
    return fields.finite_number(where, value, 0.0, True, MAX_OMEGA / scale, unit) * scale


def _check_value(where, name, value, nominal):
    """Check that a value of parameter ``name`` makes a valid drive from the nominal one."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(value):
        raise ParamError(where, value, 'a finite number')
    if is_start(name):
        return check_start_value(where, name, value)
    try:
        apply_settings(nominal, {name: value})
    except ParamError as exc:
        raise ParamError(where, value, exc.valid, f'outside the valid range of {name}') from None


def _distribution(where, name, dist, nominal):
    """Return the checked distribution ``dist`` of parameter ``name`` (at ``where``)."""
    kind = _kind(where, name, dist)
    if kind in ('uniform', 'normal') or (kind == 'grid' and 'values' not in dist):
        return _ranged(where, name, kind, dist, nominal)
    return _listed(where, name, dist, nominal)


def _kind(where, name, dist) -> str:
    """Return the kind of distribution ``dist`` names, its keys checked against that kind."""
    if not isinstance(dist, dict) or 'dist' not in dist:
        raise ParamError(where, dist, 'a mapping {dist: ' + ' | '.join(DISTRIBUTIONS) + ', ...}')
    kind = dist['dist']
    if kind not in DISTRIBUTIONS:
        raise ParamError(f'{where}.dist', kind, 'one of ' + ', '.join(DISTRIBUTIONS))
    required, optional = DISTRIBUTIONS[kind]
    fields.mapping(where, dist, required | optional | {'dist'}, required=sorted(required))
    if name == 'n' and kind not in ('list', 'grid'):
        raise ParamError(f'{where}.dist', kind, 'list or grid (n is a whole number)')
    return kind


def _ranged(where, name, kind, dist, nominal) -> dict:
    """Return a distribution over [low, high]: uniform, truncated normal or an even grid."""
    if kind == 'grid' and not {'low', 'high', 'points'} <= set(dist):
        raise ParamError(where, dist, 'a grid with values: [...] or low, high and points')
    out = {'dist': kind}
    for key in ('low', 'high', 'mean'):
        if key in dist:
            _check_value(f'{where}.{key}', name, dist[key], nominal)
            out[key] = float(dist[key])
    if not out['high'] > out['low']:
        raise ParamError(f'{where}.high', dist['high'],
                         f'greater than low = {out["low"]:g} (the range is empty)')
    if kind == 'normal':
        _check_normal(where, out, dist)
    if kind == 'grid':
        out['points'] = _int(f'{where}.points', dist['points'], 2, MAX_SAMPLES)
        out['values'] = [float(v) for v in np.linspace(out['low'], out['high'],
                                                        out['points'])]
    return out


def _listed(where, name, dist, nominal) -> dict:
    """Return a distribution over listed values (a list, or a grid given by its values)."""
    values = dist['values']
    if not isinstance(values, list) or not values:
        raise ParamError(f'{where}.values', values, 'a non-empty list of values')
    if len(values) > MAX_SAMPLES:
        raise ParamError(f'{where}.values', '...', f'at most {MAX_SAMPLES} values')
    for v in values:
        if name == 'n' and (isinstance(v, bool) or not isinstance(v, int)):
            raise ParamError(f'{where}.values', v, 'whole numbers of balls')
        _check_value(f'{where}.values', name, v, nominal)
    return {'dist': dist['dist'], 'values': [int(v) if name == 'n' else float(v)
                                             for v in values]}


def _check_normal(where, out, dist):
    """Check a truncated normal: its mean within its bounds, its spread not lost to them."""
    width = out['high'] - out['low']
    if not out['low'] <= out['mean'] <= out['high']:
        raise ParamError(f'{where}.mean', dist['mean'],
                         f'[{out["low"]:g}, {out["high"]:g}] (between low and high)')
    out['std'] = fields.finite_number(f'{where}.std', dist['std'], 0.0, True)
    if out['std'] > width:
        raise ParamError(f'{where}.std', dist['std'], f'(0, {width:g}] (at most high - low)',
                         'the bounds would cut the normal to almost uniform: use dist: uniform')
    if out['std'] < 1e-9 * max(abs(out['mean']), width):
        raise ParamError(f'{where}.std', dist['std'], f'at least {1e-9 * width:g}',
                         'a spread below the round-off of the mean draws one value')


def _integrator(value) -> str:
    """Return compute.run.integrator, one of integrate.INTEGRATORS."""
    from abb_ros.model.dynamics.integrate import INTEGRATORS
    if value not in INTEGRATORS:
        raise ParamError('compute.run.integrator', value, ' or '.join(INTEGRATORS))
    return value
