"""One partition of a sweep: its drives computed by batched compiled kernels.

:func:`compute_partition` is the unit of work a Dask worker runs (and the serial path calls
in-process): a block of samples, all computed by a few kernel calls, never one task per
sample. Drives are grouped by ball count n (a kernel batch shares n):

- ``stability``: the in-plane and out-of-plane |lambda|max at the balanced equilibrium
  (symmetric fan, Eq. 26; for n >= 3 the transverse multipliers, ``neutral_modes`` the
  family's neutral ones removed) at every speed of the spec, by
  :func:`abb_ros.model.stability.floquet.multipliers_batch` over all (drive, speed) pairs at once
  (its one-thread build, ``floquet.SERIAL``: a worker is one process with one thread); a drive
  with heights or a leaning rotor axis has the coupled linearisation's lam_max over a spindle
  period in both columns (:mod:`abb_ros.model.stability.coupled`, one speed batch per drive);
- ``run``: the nonlinear equations integrated from the scenario's initial state with its
  speed profile by :class:`abb_ros.model.dynamics.batch.BatchRun`, which reduces each
  trajectory to its metrics inside the kernel (``compute.run.integrator: rk4``), or by
  :class:`abb_ros.model.dynamics.batch.AdaptiveRuns`, the adaptive integrator's runs one
  after the other, their metrics read from its dense output at every step of dt
  (``adaptive``).

A drive's result depends only on its own parameters (every kernel treats the points of a
batch independently), so the result of a sample is the same whatever partition it is in and
wherever it runs. A run that blows up is recorded as failed (``status`` ``nonfinite`` or
``envelope`` and its ``cause``); the others go on.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.state import StateLayout, wrap_degrees
from abb_ros.model.parameters.params import DIMENSIONLESS_NAMES, apply_settings
from abb_ros.sweep.starts import initial_states, is_start

__all__ = ['compute_partition', 'STATUS_NAMES', 'partition_params', 'warm_up']

OVERLAP = -1
"""Status of a run not started: its drawn ball angles overlap (balls with contact)."""
STATUS_NAMES = {kernels.OK: 'ok', kernels.NONFINITE: 'nonfinite', kernels.ENVELOPE: 'envelope',
                OVERLAP: 'overlap'}
DERIVED = ('omega0',) + tuple(n for n in DIMENSIONLESS_NAMES if n != 'wbar') + ('n',)


def partition_params(spec, columns) -> list:
    """Return each sample's DriveParams: the nominal drive (scenario + base) with its draws."""
    nominal = spec.scenario.params
    names = [k for k in columns if not is_start(k)]
    count = len(next(iter(columns.values())))
    out = []
    for i in range(count):
        settings = {k: (int(columns[k][i]) if k == 'n' else float(columns[k][i]))
                    for k in names}
        out.append(apply_settings(nominal, settings)[0])
    return out


def compute_partition(spec, index: int, columns: dict) -> dict:
    """Compute the results of the samples ``columns`` (parameter -> values) of partition ``index``.

    Returns an ordered mapping column -> numpy array (or list of arrays for the ball angles),
    see docs/sweep.md for the columns.
    """
    start, stop = spec.partition_bounds(index)
    count = stop - start
    if any(len(v) != count for v in columns.values()):
        raise ValueError(f'partition {index} holds {count} samples')
    params = partition_params(spec, columns)
    out = {'sample': np.arange(start, stop, dtype=np.int64),
           'partition': np.full(count, index, dtype=np.int64)}
    for name, values in columns.items():
        out[name] = np.asarray(values)
    for name in DERIVED:
        if name not in out:
            values = [getattr(p, name) for p in params]
            out[name] = np.asarray(values, dtype=np.int64 if name == 'n' else float)
    groups = {}
    for i, p in enumerate(params):
        groups.setdefault(p.n_balls, []).append(i)
    groups = {n: np.asarray(idx) for n, idx in sorted(groups.items())}
    if spec.speeds is not None:
        out.update(_stability(spec, params, groups))
    if spec.run is not None:
        out.update(_runs(spec, params, groups, columns))
    if spec.speeds is not None:
        out['balanced'] = out['balanced_op'].copy()
    else:
        out['balanced'] = out['run_balanced'].copy()
    return out


def _multipliers(compute):
    """Return compute(), a batch of multipliers; a drive over its step limit names the spec."""
    from abb_ros.model.parameters.params import ParamError
    try:
        return compute()
    except ParamError as exc:
        if exc.name != 'omega':
            raise
        raise ParamError('compute.stability', exc.value, exc.valid,
                         f'a drawn drive at this speed: {exc.why}; narrow its parameters or '
                         'raise the slowest speed') from None


def _stability(spec, params, groups) -> dict:
    from abb_ros.model.stability.coupled import lam_max_batch
    from abb_ros.model.stability.floquet import SERIAL, multipliers_batch
    speeds = spec.speeds
    count = len(params)
    S = speeds.size
    lam = {plane: np.empty((count, S)) for plane in ('in', 'out')}
    exists = np.empty(count, dtype=bool)
    neutral = np.zeros(count, dtype=np.int64)
    for idx in groups.values():
        off = idx[np.array([params[i].off_plane for i in idx], dtype=bool)]
        if off.size:        # heights or a lean: the coupled lam_max in both columns
            res = _multipliers(lambda: lam_max_batch(
                [params[i] for i in off for _ in range(S)], np.tile(speeds, off.size)))
            lam['in'][off] = lam['out'][off] = res.lam.reshape(off.size, S)
            exists[off] = res.exists.reshape(off.size, S)[:, 0]
            neutral[off] = res.neutral.reshape(off.size, S)[:, 0]
        idx = np.setdiff1d(idx, off)
        if not idx.size:
            continue
        plist = [params[i] for i in idx for _ in range(S)]
        omegas = np.tile(speeds, idx.size)
        for plane in ('in', 'out'):
            res = _multipliers(lambda: multipliers_batch(plist, omegas, plane, kern=SERIAL))
            lam[plane][idx] = res.lam.reshape(idx.size, S)
            if plane == 'in':
                neutral[idx] = res.neutral.reshape(idx.size, S)[:, 0]
        exists[idx] = res.exists.reshape(idx.size, S)[:, 0]
    op = int(np.searchsorted(speeds, spec.operating_omega))
    worst = np.maximum(lam['in'], lam['out'])
    return {
        'balanced_equilibrium_exists': exists,
        'neutral_modes': neutral,
        'lam_in_op': lam['in'][:, op],
        'lam_out_op': lam['out'][:, op],
        'balanced_op': exists & (lam['in'][:, op] < 1.0) & (lam['out'][:, op] < 1.0),
        'lam_in_max': lam['in'].max(axis=1),
        'lam_out_max': lam['out'].max(axis=1),
        'omega_worst': speeds[np.argmax(worst, axis=1)],
        'balanced_all_speeds': exists & (worst.max(axis=1) < 1.0),
    }


def _runs(spec, params, groups, columns) -> dict:
    from abb_ros.model.dynamics.batch import (
        FAIL_TIME,
        PEAK_RBAR,
        TIME_ABOVE,
        AdaptiveRuns,
        BatchRun,
    )
    from abb_ros.model.dynamics.integrate import StateError
    scen = spec.scenario
    dt = spec.run['dt']
    limit = spec.run['rbar_limit']
    nsteps = int(round(spec.run['duration'] / dt))
    # speed commands take effect at the first step at or after their time
    cmd_steps = [(max(0, math.ceil(c.t / dt - 1e-9)), c.omega) for c in scen.commands]
    cmd_steps = [(s, om) for s, om in cmd_steps if s < nsteps]
    count = len(params)
    res = {'final_rbar': np.empty(count), 'peak_rbar': np.empty(count),
           'settle_time': np.empty(count), 'time_above_limit': np.empty(count),
           'omega_final': np.empty(count)}
    phi_final = [None] * count
    status = np.empty(count, dtype=np.int64)
    fail_time = np.empty(count)
    for n, idx in groups.items():
        plist = [params[i] for i in idx]
        y0, overlap = _initial(scen, columns, idx, plist)
        S = np.array([scen.spindle.pack(scen.omega)] * idx.size)
        if spec.run.get('integrator', 'rk4') == 'adaptive':
            br = AdaptiveRuns(plist, y0, scen.spindle, scen.omega, dt, limit)
        else:
            br = BatchRun(plist, y0, S, dt, limit)
        br.status[overlap] = OVERLAP       # never advanced
        for step, omega in cmd_steps:
            br.advance(step - br.steps)
            br.set_omega_cmd(omega)
        br.advance(nsteps - br.steps)
        layout = StateLayout.of(n)
        res['final_rbar'][idx] = br.rbar
        res['peak_rbar'][idx] = br.metrics[:, PEAK_RBAR]
        res['settle_time'][idx] = br.settle_time
        res['time_above_limit'][idx] = br.metrics[:, TIME_ABOVE]
        res['omega_final'][idx] = layout.omega(br.Y)
        phi = wrap_degrees(layout.phi(br.Y))
        for j, i in enumerate(idx):
            phi_final[i] = phi[j]
        status[idx] = br.status
        fail_time[idx] = br.metrics[:, FAIL_TIME]
    failed = status != kernels.OK
    cause = [str(StateError(int(s), float(t))) if s not in (kernels.OK, OVERLAP) else
             'the drawn ball angles overlap (contact on): not run' if s == OVERLAP else ''
             for s, t in zip(status, fail_time)]
    return {**res, 'phi_final_deg': phi_final,
            'status': np.asarray([STATUS_NAMES[int(s)] for s in status], dtype=object),
            'failed': failed, 'cause': np.asarray(cause, dtype=object), 'fail_time': fail_time,
            'run_balanced': ~failed & (res['final_rbar'] <= limit)}


def _initial(scen, columns, idx, plist):
    """Return the initial states of the samples ``idx`` and which of them overlap."""
    from abb_ros.model.dynamics.initial import initial_state
    from abb_ros.model.parameters.params import ParamError
    n = plist[0].n_balls
    phi0, deck0 = initial_states(scen, columns, idx, n)
    y0 = []
    overlap = np.zeros(len(plist), dtype=bool)
    for j, p in enumerate(plist):
        phi = None if phi0 is None else phi0[j]
        try:
            y0.append(initial_state(p, scen.omega, phi, tuple(deck0[j])))
        except ParamError:            # balls that touch started inside each other
            overlap[j] = True
            y0.append(StateLayout.of(n).pack(deck=tuple(deck0[j]), phi=phi, omega=scen.omega))
    return np.array(y0), overlap


def warm_up(spec) -> None:
    """Compute the first sample of ``spec`` and discard it.

    This loads (or compiles) the kernels of this process, so that timings and deadlines see the
    steady state.
    """
    from abb_ros.sweep.sampling import draw_samples
    one = dataclasses.replace(spec, partition_size=1)
    compute_partition(one, 0, {k: v[:1] for k, v in draw_samples(spec).items()})
