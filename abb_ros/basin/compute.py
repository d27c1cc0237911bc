"""One partition of a basin study: the scenario run from each of its starts, each end classified.

:func:`compute_partition` is the unit of work a Dask worker runs (and the serial path calls
in-process). Every start is run by :func:`abb_ros.app.headless.run_scenario`, the very run of
``abb-sim run`` (same integrator, same step, speed commands at the same publish instants), so
a row reproduces ``abb-sim run`` from that start bit for bit; the samples it returns at the
publish rate give the rest window of :func:`abb_ros.model.stability.outcomes.classify`. A
start whose balls overlap (balls with contact) is not run (class ``overlap``, left out of the
fraction);
a run that blows up is class ``failed`` with its cause (and no final state). A start's
result depends on nothing but the spec and the start, so it is the same in any partition, on
any worker.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from abb_ros.app.headless import run_scenario
from abb_ros.basin.spec import start_columns
from abb_ros.model.dynamics.integrate import StateError
from abb_ros.model.dynamics.state import StateLayout, wrap_degrees
from abb_ros.model.parameters.params import ParamError
from abb_ros.model.stability.outcomes import classify

__all__ = ['compute_partition', 'run_start', 'OVERLAP']

OVERLAP = 'overlap'
"""Class of a start whose balls overlap (contact on): not run, not counted."""


def run_start(spec, phi_deg):
    """Run the spec's scenario from ball angles ``phi_deg``; return (t, ys, cause).

    ``cause`` is '' for a complete run, the StateError's text for one that blew up, or None
    for overlapping balls (t, ys None in both cases).
    """
    scen = dataclasses.replace(spec.scenario, phi0=np.radians(np.asarray(phi_deg, float)),
                               commands=list(spec.scenario.commands))
    try:
        result = run_scenario(scen, **spec.options)
    except StateError as exc:
        return None, None, str(exc)
    except ParamError as exc:
        if exc.name != 'phi0':
            raise
        return None, None, None
    return result.t, result.y, ''


def compute_partition(spec, index: int, columns: dict) -> dict:
    """Compute the rows of the starts ``columns`` (phi1_deg, ... -> values) of partition ``index``.

    Returns column -> numpy array; docs/basin.md lists the columns.
    """
    start, stop = spec.partition_bounds(index)
    count = stop - start
    names = start_columns(spec.n)
    phi0 = np.stack([np.asarray(columns[k], dtype=float) for k in names], axis=1)
    if phi0.shape[0] != count:
        raise ValueError(f'partition {index} holds {count} starts')
    p = spec.scenario.params
    layout = StateLayout.of(p.n_balls)
    out = {'sample': np.arange(start, stop, dtype=np.int64),
           'partition': np.full(count, index, dtype=np.int64)}
    for i, name in enumerate(names):
        out[name] = phi0[:, i].copy()
    outcome = np.empty(count, dtype=object)
    final_rbar = np.full(count, np.nan)
    final_phi = np.full((count, p.n_balls), np.nan)
    omega = np.full(count, np.nan)
    residual = np.full(count, np.nan)
    motion = np.full(count, np.nan)
    cause = np.empty(count, dtype=object)
    for j in range(count):
        t, ys, why = run_start(spec, phi0[j])
        cause[j] = why or ''
        if ys is None:
            outcome[j] = OVERLAP if why is None else 'failed'
            continue
        outcome[j], residual[j], motion[j] = classify(p, t, ys, spec.rbar_limit,
                                                      spec.rest_tol_deg)
        final_rbar[j] = layout.rbar(ys[-1], p.R)
        final_phi[j] = wrap_degrees(layout.phi(ys[-1]))
        omega[j] = layout.omega(ys[-1])
    out['balanced'] = outcome == 'balanced'
    out['outcome'] = outcome
    out['final_rbar'] = final_rbar
    for i in range(p.n_balls):
        out[f'phi{i + 1}_final_deg'] = final_phi[:, i].copy()
    out['omega_final'] = omega
    out['eq26_residual'] = residual
    out['rest_motion_deg'] = motion
    out['cause'] = cause
    return out
