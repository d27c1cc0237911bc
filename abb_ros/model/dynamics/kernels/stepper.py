"""Time stepping: one step of the model, and the drivers that take many.

A step (:func:`step`) is one classical RK4 step of the whole system
(:mod:`abb_ros.model.dynamics.kernels.rk4`), or, while balls touch, the multirate contact step
(:mod:`abb_ros.model.dynamics.kernels.multirate`) or RK4 sub-steps (torque mode); under rolling
resistance each (sub)step locates its regime switches
(:mod:`abb_ros.model.dynamics.kernels.rolling_events`). :func:`advance` and :func:`trajectory` take
many steps, time recomputed from the integer step count at every step (no accumulated
drift); every step's new state is checked against the envelope (:func:`check_state`).
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.model.dynamics.kernels.contact_steps import (
    MIS_IMPACT_REFINE,
    contact_regimes,
    retake_substeps,
)
from abb_ros.model.dynamics.kernels.layout import (
    ENVELOPE,
    MAX_ANGLE,
    MAX_BALL_RATE,
    MAX_TRANSLATION,
    N_WORK_ROWS,
    NONFINITE,
    OK,
    P_CONTACT_E,
    P_ROLLING_MU,
    S_MODE,
    SPINDLE_TORQUE,
    STAT_MOST_SUBSTEPS,
    STAT_REFINED,
    STAT_SUBSTEPS,
    STAT_SWITCHES,
    W_CACHE,
    W_STATS,
    kernel,
    solver_scratch,
    work_stages,
)
from abb_ros.model.dynamics.kernels.multirate import contact_step, mis_contact_step
from abb_ros.model.dynamics.kernels.rhs import accel, on_paper
from abb_ros.model.dynamics.kernels.rk4 import paper_rk4, rk4_substep, rk4_substeps
from abb_ros.model.dynamics.kernels.rolling_events import MAX_SWITCHES, rolling_substep
from abb_ros.model.dynamics.state import DECK, PHI


@kernel
def check_state(y, n):
    """Return OK, NONFINITE or ENVELOPE for the state y."""
    N = PHI + n
    for i in range(2 * N):
        if not math.isfinite(y[i]):
            return NONFINITE
    for i in range(DECK, DECK + 3):
        if abs(y[i]) > MAX_TRANSLATION:
            return ENVELOPE
    for i in range(DECK + 3, PHI):
        if abs(y[i]) > MAX_ANGLE:
            return ENVELOPE
    for i in range(n):
        if abs(y[N + PHI + i]) > MAX_BALL_RATE:
            return ENVELOPE
    return OK


@kernel
def step(t, dt, y, n, P, S, stages, solver, cache):
    """Take one step of dt from (t, y), y in place; return (status, sub-steps, switches).

    One classical RK4 step, or, while balls touch, sub-steps of dt /
    :func:`abb_ros.model.dynamics.kernels.contact_steps.contact_substeps`: the multirate step
    (:func:`abb_ros.model.dynamics.kernels.multirate.contact_step`: only the contact forces
    sub-stepped), or, in torque mode and with rolling resistance, RK4 sub-steps of the whole
    system (in an impact MIS_IMPACT_REFINE times as many, as the multirate step's). A step
    with a contact resolved as resting, in one RK4 step or in sub-steps, is taken again when
    :func:`abb_ros.model.dynamics.kernels.contact_steps.retake_substeps` says so (not with rolling
    resistance); with rolling resistance each (sub)step locates its regime switches
    (:func:`abb_ros.model.dynamics.kernels.rolling_events.rolling_substep`, ``cache`` (3, 2N)
    carried from step to step). ``stages``: the RK4 buffers (:class:`Stages`), ``solver`` the
    scratch of :func:`abb_ros.model.dynamics.kernels.rhs.accel`. Returns the :func:`check_state`
    status of the new state (when it is not OK, y is put back to its value before the step),
    the sub-steps (the multirate step's fast ones) and the located switches.
    """
    ysave = stages.ysave
    n2 = y.shape[0]
    for i in range(n2):
        ysave[i] = y[i]
    sub = 1
    impact = False
    resting = False
    if P[P_CONTACT_E] > 0.0 and n > 1:
        sub, impact, resting = contact_regimes(y, n, P, dt, False)
    switches = 0
    if P[P_ROLLING_MU] > 0.0 and n > 0 and S[S_MODE] != SPINDLE_TORQUE:
        switches = rolling_substeps(t, dt, sub, y, n, P, S, stages, solver, cache)
    elif sub == 1 and not impact and not resting:
        rk4_substep(t, dt, y, n, P, S, stages, solver)
    elif sub > 1 and S[S_MODE] != SPINDLE_TORQUE:
        sub = contact_step(t, dt, y, ysave, n, P, S, (sub, impact), np.empty((0, n2)), solver)
    else:
        sub = resolved_substeps(t, dt, y, n, P, S, stages, solver, sub, impact)
    status = check_state(y, n)
    if status != OK:
        for i in range(n2):
            y[i] = ysave[i]
    return status, sub, switches


@kernel
def paper_step(t, h, y, n, P, S, stages, solver):
    """:func:`step` where :func:`~.rhs.on_paper` holds: one RK4 step of h, y in place.

    The same numbers as :func:`step` on that path, with the stages calling
    :func:`~.rhs.paper_deriv` (fewer reference counts: about 20 % less time per step).
    Returns the :func:`check_state` status (y put back when it is not OK).
    """
    ysave = stages.ysave
    for i in range(y.shape[0]):
        ysave[i] = y[i]
    paper_rk4(t, h, y, n, P, S, stages, solver)
    status = check_state(y, n)
    if status != OK:
        for i in range(y.shape[0]):
            y[i] = ysave[i]
    return status


@kernel
def rolling_substeps(t, dt, sub, y, n, P, S, stages, solver, cache):
    """Take ``sub`` sub-steps of dt / sub with rolling resistance, y in place.

    Each locates its rolling regime switches
    (:func:`abb_ros.model.dynamics.kernels.rolling_events.rolling_substep`); returns how many.
    """
    events = np.empty((MAX_SWITCHES, 1 + n + y.shape[0]))
    h = dt / sub
    switches = 0
    for j in range(sub):
        switches += rolling_substep(t + j * h, h, y, n, P, S, stages, solver, events, cache)
    return switches


@kernel
def resolved_substeps(t, dt, y, n, P, S, stages, solver, sub, impact):
    """Take whole-system RK4 sub-steps of dt, y in place; return how many were taken.

    ``sub`` of them in torque mode (MIS_IMPACT_REFINE times as many in an impact), or one
    RK4 step where a contact is resolved in one step; both are taken again from
    ``stages.ysave`` when a resting contact did not rest
    (:func:`abb_ros.model.dynamics.kernels.contact_steps.retake_substeps`): RK4 sub-steps in
    torque mode, else the multirate step.
    """
    ysave = stages.ysave
    if impact:
        sub = int(math.ceil(sub * MIS_IMPACT_REFINE))
    rk4_substeps(t, dt, sub, y, n, P, S, stages, solver)
    forced = retake_substeps(ysave, y, n, P, dt, impact, sub, MIS_IMPACT_REFINE)
    if forced > 0:
        for i in range(y.shape[0]):
            y[i] = ysave[i]
        if S[S_MODE] == SPINDLE_TORQUE:
            sub = forced
            rk4_substeps(t, dt, sub, y, n, P, S, stages, solver)
        else:
            sub = mis_contact_step(t, dt, y, n, P, S, forced, np.empty((0, y.shape[0])), solver)
    return sub


@kernel
def step_uncached(t, dt, y, n, P, S, stages, solver):
    """Take one :func:`step` (:func:`paper_step` on its path) with no rolling cache carried.

    Returns (status, sub-steps).
    """
    if on_paper(n, P, S):
        return paper_step(t, dt, y, n, P, S, stages, solver), 1
    n2 = y.shape[0]
    if P[P_ROLLING_MU] > 0.0:
        cache = np.zeros((3, n2))
    else:
        cache = stages.ysave.reshape((1, n2))     # not used: no allocation on the paper's path
    status, sub, _ = step(t, dt, y, n, P, S, stages, solver, cache)
    return status, sub


@kernel
def advance(y, t0, dt, step0, nsteps, P, S, work):
    """Advance y in place by nsteps steps of dt from t = t0 + step0 dt.

    Time is recomputed from the integer step count at every step (no accumulated drift).
    Each step is a :func:`paper_step` where only the paper's terms act, else a :func:`step`.
    ``work``: the buffers of :func:`abb_ros.model.dynamics.kernels.layout.make_work` (stages,
    statistics, rolling cache; rows W_*). Returns (steps_done, status); on a bad state the
    state of the last good step is kept.
    """
    n = y.shape[0] // 2 - PHI
    stages = work_stages(work)
    solver = solver_scratch(n)
    if work.shape[0] >= N_WORK_ROWS:
        cache = work[W_CACHE:W_CACHE + 3]
    else:
        cache = np.zeros((3, 2 * (PHI + n)))
    stats = work.shape[0] > W_STATS
    paper = on_paper(n, P, S)
    for s in range(nsteps):
        t = t0 + (step0 + s) * dt
        if paper:
            status, sub, switches = paper_step(t, dt, y, n, P, S, stages, solver), 1, 0
        else:
            status, sub, switches = step(t, dt, y, n, P, S, stages, solver, cache)
        if sub > 1 and stats:                   # contact statistics
            work[W_STATS, STAT_REFINED] += 1.0
            work[W_STATS, STAT_MOST_SUBSTEPS] = max(work[W_STATS, STAT_MOST_SUBSTEPS],
                                                    float(sub))
            work[W_STATS, STAT_SUBSTEPS] += float(sub)
        if switches > 0 and stats:              # located rolling switches
            work[W_STATS, STAT_SWITCHES] += float(switches)
        if status != OK:
            return s, status
    return nsteps, OK


@kernel
def paper_advance(y, t0, dt, step0, nsteps, P, S, work):
    """:func:`advance` where :func:`~.rhs.on_paper` holds: :func:`paper_step` only.

    The same numbers as :func:`advance` on that path. Its machine code holds none of the
    contact, rolling and torque steps, so it compiles in a fraction of :func:`advance`'s time:
    what a node on the paper's path needs before its first message. Returns
    (steps_done, status).
    """
    n = y.shape[0] // 2 - PHI
    stages = work_stages(work)
    solver = solver_scratch(n)
    for s in range(nsteps):
        status = paper_step(t0 + (step0 + s) * dt, dt, y, n, P, S, stages, solver)
        if status != OK:
            return s, status
    return nsteps, OK


@kernel
def trajectory(y, t0, dt, step0, nsteps, every, P, S, work, out):
    """Like :func:`advance`, storing y after every ``every`` steps into ``out`` rows.

    Returns (steps_done, rows_written, status).
    """
    rows = 0
    done = 0
    while done < nsteps:
        chunk = min(every, nsteps - done)
        got, status = advance(y, t0, dt, step0 + done, chunk, P, S, work)
        done += got
        if status != OK:
            return done, rows, status
        if chunk == every:
            for i in range(y.shape[0]):
                out[rows, i] = y[i]
            rows += 1
    return done, rows, OK


@kernel
def advance_accel(y, t0, dt, step0, nsteps, P, S, work, qdd):
    """:func:`advance`, then q'' at the state reached into ``qdd`` (N,) when every step was done.

    The state and q'' of ``advance`` and then ``accel`` at t = t0 + (step0 + nsteps) dt, in
    one call (the live node's publish period: its IMU reads q''). Returns (steps_done, status).
    """
    done, status = advance(y, t0, dt, step0, nsteps, P, S, work)
    return accel_reached(y, t0, dt, step0, done, status, P, S, qdd)


@kernel
def paper_advance_accel(y, t0, dt, step0, nsteps, P, S, work, qdd):
    """:func:`advance_accel` where :func:`~.rhs.on_paper` holds (:func:`paper_advance`)."""
    done, status = paper_advance(y, t0, dt, step0, nsteps, P, S, work)
    return accel_reached(y, t0, dt, step0, done, status, P, S, qdd)


@kernel
def accel_reached(y, t0, dt, step0, done, status, P, S, qdd):
    """Write q'' at the state reached into ``qdd`` if all went well; return (done, status)."""
    if status == OK:
        n = y.shape[0] // 2 - PHI
        accel(t0 + (step0 + done) * dt, y, n, P, S, qdd, solver_scratch(n))
    return done, status
