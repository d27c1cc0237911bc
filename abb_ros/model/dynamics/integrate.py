"""Time integration of the nonlinear model: a fixed-step RK4 for real time, and a reference.

:class:`Simulation` advances the state of :mod:`abb_ros.model.dynamics.equations` with the compiled
classical RK4 of :mod:`abb_ros.model.dynamics.kernels`, many steps per call; time is the integer
step count times ``dt`` (no drift). :func:`abb_ros.model.dynamics.reference.reference_solution`
integrates the same right-hand side with scipy's adaptive DOP853 at tight tolerances.

The spindle is one of the models of :mod:`abb_ros.model.dynamics.spindle` (a prescribed
speed profile or a torque-driven motor); :meth:`Simulation.set_command` sets its command.
"""

from __future__ import annotations

import math

import numpy as np

from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.equations import solver_buffers
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.kernels.adaptive import (
    AD_H,
    AD_LIVE,
    AD_NFEV,
    AD_REJECTS,
    adaptive_buffers,
)
from abb_ros.model.dynamics.kernels.layout import (
    STAT_MOST_SUBSTEPS,
    STAT_REFINED,
    STAT_SUBSTEPS,
    STAT_SWITCHES,
    W_STATS,
)
from abb_ros.model.dynamics.spindle import SpindleMotor, TorqueMotor
from abb_ros.model.dynamics.state import StateLayout
from abb_ros.model.parameters.params import DriveParams, ParamError, zero_text

__all__ = ['DEFAULT_DT', 'MAX_RUN_STEPS', 'StateError', 'Simulation', 'INTEGRATORS',
           'ADAPTIVE_RTOL', 'adaptive_atol', 'fixed_step_reason']

DEFAULT_DT = 1.0 / 10000.0
"""Default fixed step [s] (10 kHz); see docs/verification.md for the accuracy
study that chose it."""

MAX_RUN_STEPS = 100_000_000
"""Most fixed steps of one run (duration / dt): 10^4 simulated seconds at 10 kHz, hours of
work and a bag of gigabytes; a longer run is refused before it starts."""

SMALLEST_NORMAL = float(np.finfo(float).tiny)
"""[-] 2.2e-308: a state coordinate below it in magnitude is set to 0 after each kernel call.
A mode that decays to nothing (the out-of-plane Z', alpha', beta' at P3, from round-off)
otherwise stalls among the subnormal doubles (x (1 - eps) rounds back to x) and every
operation on them takes the processor's slow path: 1.44 times the cost of a step of the
Table 1 drive at P3 after 130 s (2.11 on a loaded machine; benchmarks/bench_core.py)."""

CONTACT_DT_VERIFIED = (1e-5, 2e-4)
"""Steps [s] over which the contact step's rebound accuracy (1e-5 m/s or 7.8e-5 of the speed,
approach speeds 0.001-0.5 m/s, both spindle modes) is tested: test_contact_step_sizes.py.
Outside it a run goes on, and says so (:func:`contact_step_note`)."""


def contact_step_note(params, dt: float) -> str:
    """Return a one-line warning for a contact step outside the verified range, or ''.

    The warning applies when balls touch (contact on) and dt [s] lies outside
    :data:`CONTACT_DT_VERIFIED`.
    """
    lo, hi = CONTACT_DT_VERIFIED
    if params.contact_E <= 0 or params.n < 2 or lo <= dt <= hi:
        return ''
    return (f'integration step {dt:.3g} s outside {lo:g}..{hi:g} s, where the contact '
            'impacts\' accuracy is verified (docs/ball_size_contact_rolling.md)')



ADAPTIVE_RTOL = 1e-9
"""Relative tolerance of the adaptive integrator (absolute: :func:`adaptive_atol`). The
loosest power of ten at which its largest deck-translation error over a P3 run, against DOP853
at rtol 1e-11, is below the fixed RK4 step's at 10 kHz (1.4e-7 against 6.7e-7 of the 0.3 mm
start, n = 2 and 10); the settled ball angles then agree with RK4's within 1e-4 deg, a
hundredth of the 0.01 deg asked (test_adaptive_integrator.py, docs/verification.md)."""

ATOL_SCALE = {'theta': 1.0, 'translation': 1e-3, 'angle': 1e-2, 'phi': 1.0, 'rate': 1e3}
"""Size [SI] of each kind of coordinate at which the absolute tolerance is ADAPTIVE_RTOL of it:
the rotor and ball angles (rad), the deck's translations (m) and tilts (rad); a rate's scale is
its coordinate's times ``rate`` [1/s] (the drive's rates are below 1e3 rad/s)."""


def adaptive_atol(n: int) -> np.ndarray:
    """Return the adaptive integrator's absolute tolerance of each state component, (2N,)."""
    layout = StateLayout.of(n)
    q = np.empty(layout.N)
    q[0] = ATOL_SCALE['theta']
    q[1:4] = ATOL_SCALE['translation']
    q[4:7] = ATOL_SCALE['angle']
    q[7:] = ATOL_SCALE['phi']
    return ADAPTIVE_RTOL * np.concatenate([q, q * ATOL_SCALE['rate']])


def fixed_step_reason(params: DriveParams) -> str:
    """Return why the adaptive integrator takes the fixed RK4 step for this drive, or ''.

    Ball contact and rolling resistance switch between laws inside a step (the fixed-step
    kernels locate those switches and sub-step the contacts); the adaptive integrator does
    not, so for such a drive it falls back to the fixed step for the whole run.
    """
    if params.contact_E > 0 and params.n > 1:
        return 'ball contact (contact_E > 0)'
    if params.rolling_mu > 0 and params.n > 0:
        return 'rolling resistance (rolling_mu > 0)'
    return ''


class StateError(RuntimeError):
    """The state became non-finite or left the sane envelope; integration stopped.

    ``status`` is kernels.NONFINITE or kernels.ENVELOPE; ``t`` the time of the last good state.
    """

    def __init__(self, status: int, t: float):
        self.status = status
        self.t = t
        what = ('became non-finite' if status == kernels.NONFINITE else
                'left the sane envelope (|X|,|Y|,|Z| <= %g m, |alpha|,|beta|,|gamma| <= %g rad, '
                '|phi_i\'| <= %g rad/s)' % (kernels.MAX_TRANSLATION, kernels.MAX_ANGLE,
                                             kernels.MAX_BALL_RATE))
        super().__init__(f'state {what} after t = {t:.6f} s; integration stopped')


def _check_torque_terms(params: DriveParams, spindle) -> None:
    """Refuse torque mode with rolling resistance, rolling balls or heights off the plane.

    The free-theta equation of torque mode (docs/torque_mode.md) has ball contact but not
    yet rolling resistance, rolling balls (docs/ball_size_contact_rolling.md) or the
    heights z_P, z_G, z_B (docs/equations.md, F4).
    """
    if not isinstance(spindle, TorqueMotor):
        return
    if params.off_plane:
        name = params.off_plane_name
        raise ParamError(name, params.value(name),
                         f'{zero_text(name)} in torque mode (spindle.mode torque)',
                         'the free-theta equation does not have the heights, the leaning '
                         'axis and a second race yet')
    if params.rolling_mu > 0 or params.ball_rotation:
        name = 'rolling_mu' if params.rolling_mu > 0 else 'ball_rotation'
        raise ParamError(name, getattr(params, name), '0 in torque mode (spindle.mode torque)',
                         'the free-theta equation does not have this term yet')


class Simulation:
    """The drive's state advanced by fixed RK4 steps of ``dt`` in a compiled kernel.

    Parameters
    ----------
    params : DriveParams
    omega : float
        Initial spindle speed [rad/s] (also the initial speed command; with a
        :class:`TorqueMotor` the initial current command is 0 A).
    dt : float
        Step [s].
    spindle : ConstantSpeed | Ramp | SpindleMotor
        Spindle-speed profile; default a :class:`SpindleMotor` holding ``omega``.
    y0 : ndarray, optional
        Initial state (default :func:`initial_state`).
    integrator : str
        One of :data:`INTEGRATORS`. With ``adaptive`` the states at the step instants
        t0 + k dt that :meth:`advance` and :meth:`trajectory` return are read from the
        adaptive integrator's dense output; it falls back to ``rk4`` for a drive with ball
        contact or rolling resistance (:func:`fixed_step_reason`; :attr:`integrator_used`
        says which runs). After writing :attr:`y` directly, call :meth:`restart`.
    """

    def __init__(self, params: DriveParams, omega: float, dt: float = DEFAULT_DT,
                 spindle=None, y0=None, t0: float = 0.0, kern=None, integrator: str = 'rk4'):
        if not (math.isfinite(dt) and dt > 0):
            raise ParamError('dt', dt, '(0, inf) s')
        if integrator not in INTEGRATORS:
            raise ParamError('integrator', integrator, ' or '.join(INTEGRATORS))
        self.integrator = integrator
        self.kern = kern or kernels.JIT
        self.dt = float(dt)
        self.t0 = float(t0)
        self.steps = 0
        self.spindle = SpindleMotor() if spindle is None else spindle
        self.omega_cmd = 0.0 if isinstance(self.spindle, TorqueMotor) else float(omega)
        self._set_params(params)
        self._y0 = initial_state(params, omega) if y0 is None else np.array(y0, dtype=float)
        self.reset(self._y0)

    def _set_params(self, params: DriveParams):
        _check_torque_terms(params, self.spindle)
        self.params = params
        self.layout = StateLayout.of(params.n_balls)
        self._P = kernels.pack_params(params)
        self._work = kernels.make_work(params.n_balls)
        self._solver = solver_buffers(params.n_balls)
        self._S = self.spindle.pack(self.omega_cmd)
        self._ad, self._aw = adaptive_buffers(params.n_balls)
        self._atol = adaptive_atol(params.n_balls)

    @property
    def integrator_used(self) -> str:
        """The integrator that runs: ``integrator``, or ``rk4`` where adaptive falls back."""
        if self.integrator == 'adaptive' and not fixed_step_reason(self.params):
            return 'adaptive'
        return 'rk4'

    @property
    def adaptive_counts(self) -> dict:
        """Right-hand sides and rejected steps of the adaptive integrator so far, last step [s]."""
        return {'nfev': int(self._ad[AD_NFEV]), 'rejected': int(self._ad[AD_REJECTS]),
                'step': float(self._ad[AD_H])}

    def restart(self) -> None:
        """Restart the adaptive integrator from the present state (after an input changed)."""
        self._ad[AD_LIVE] = 0.0

    @property
    def contact_step_note(self) -> str:
        """:func:`contact_step_note` of this run's drive and step ('' when nothing to say)."""
        return contact_step_note(self.params, self.dt)

    # ---- inputs -------------------------------------------------------------------------
    def set_speed_command(self, omega_cmd: float) -> None:
        """Set the commanded spindle speed [rad/s], taken at the next step boundary."""
        self.omega_cmd = float(omega_cmd)
        self._S = self.spindle.pack(self.omega_cmd)
        self.restart()

    def set_command(self, command: float) -> None:
        """Set the spindle command, taken at the next step boundary.

        The command is the speed [rad/s], or the winding current [A] for a
        :class:`TorqueMotor`.
        """
        self.set_speed_command(command)

    @property
    def motor_current(self) -> float:
        """Winding current [A] of a :class:`TorqueMotor` now (NaN in speed modes)."""
        if not isinstance(self.spindle, TorqueMotor):
            return math.nan
        return self.spindle.current(self.omega, self.omega_cmd)

    @property
    def motor_torque(self) -> float:
        """Electromagnetic torque K_t i [N m] of a :class:`TorqueMotor`.

        NaN in speed modes; joint_states.effort[0].
        """
        current = self.motor_current
        return math.nan if math.isnan(current) else self.spindle.K_t * current

    def set_spindle(self, spindle) -> None:
        """Set a new spindle model at the next step boundary.

        Into torque mode the command becomes 0 A, out of it the present speed
        (:meth:`set_command` to choose).
        """
        _check_torque_terms(self.params, spindle)
        torque = isinstance(spindle, TorqueMotor)
        if torque != isinstance(self.spindle, TorqueMotor):
            self.omega_cmd = 0.0 if torque else self.omega
        self.spindle = spindle
        self._S = spindle.pack(self.omega_cmd)
        self.restart()

    def set_params(self, params: DriveParams) -> None:
        """Apply new physical parameters at the current step boundary (same n)."""
        for name in ('n', 'race2.n'):
            if params.value(name) != self.params.value(name):
                raise ParamError(name, params.value(name), f'{self.params.value(name)} until '
                                 f'reset (a change of {name} needs a new state: use '
                                 'reset(params=...))')
        self._set_params(params)

    def reset(self, y0=None, params: DriveParams | None = None) -> None:
        """Back to the initial state (or y0), optionally with new parameters (any n).

        Time keeps running (the step counter is not reset), so clocks never go backwards.
        """
        if params is not None:
            old, races = self.layout, (self.params.n, self.params.race2_n)
            self._set_params(params)
            if (params.n, params.race2_n) != races:
                self._y0 = initial_state(params, float(old.omega(self._y0)))
        y0 = self._y0 if y0 is None else np.asarray(y0, dtype=float)
        if y0.shape != (self.layout.size,):
            raise ParamError('y0', y0.shape, f'shape ({self.layout.size},)')
        self.y = np.array(y0, dtype=float)
        self.restart()

    # ---- stepping -----------------------------------------------------------------------
    @property
    def t(self) -> float:
        """Simulated time [s] = t0 + steps * dt."""
        return self.t0 + self.steps * self.dt

    def on_paper(self) -> bool:
        """Whether only rigid point-mass terms act now (:func:`~.kernels.rhs.on_paper`).

        Eqs. 18-24, with heights and a leaning rotor axis where set. Then :meth:`advance`
        calls the paper's own compiled stepping (the same numbers, a fraction of the compile
        time); a torque command, contact or rolling resistance takes the general one.
        """
        return bool(kernels.PY.on_paper(self.params.n_balls, self._P, self._S))

    def advance(self, nsteps: int) -> None:
        """Advance by nsteps steps.

        Raises :class:`StateError` on a bad state (the last good state is kept and time stops
        there).
        """
        INTEGRATORS[self.integrator_used].advance(self, int(nsteps))

    def advance_accelerations(self, nsteps: int, qdd: np.ndarray) -> None:
        """Advance by nsteps steps, then write q'' at the state reached into ``qdd`` (N,).

        :meth:`advance` then :meth:`accelerations`, the same numbers, in one compiled call on
        the fixed-step path. Raises :class:`StateError` like :meth:`advance` (``qdd`` is then
        not written).
        """
        INTEGRATORS[self.integrator_used].advance_accelerations(self, int(nsteps), qdd)

    def _check(self, done, status) -> None:
        """Count the steps done, flush subnormals, raise on a bad status.

        Coordinates below :data:`SMALLEST_NORMAL` become 0; :class:`StateError` when the
        kernel's status is bad.
        """
        self.steps += int(done)
        np.copyto(self.y, 0.0, where=np.abs(self.y) < SMALLEST_NORMAL)
        if status != kernels.OK:
            raise StateError(int(status), self.t)

    def trajectory(self, nsteps: int, every: int, out: np.ndarray | None = None
                   ) -> np.ndarray:
        """Advance nsteps; return the states after every ``every`` steps.

        Shape (nsteps // every, 2N), in ``out`` when given (at least that many rows). Raises
        :class:`StateError` like :meth:`advance`; ``out`` then holds the states of the
        (steps done) // every periods completed.
        """
        rows = int(nsteps) // int(every)
        if out is None:
            out = np.empty((rows, self.y.size))
        return out[:INTEGRATORS[self.integrator_used].trajectory(self, int(nsteps), int(every),
                                                                  out)]

    # ---- outputs ------------------------------------------------------------------------
    def accelerations(self) -> np.ndarray:
        """Return q'' at the current state, shape (N,) (a new array; the scratch is reused)."""
        qdd = np.empty(self.N)
        self.kern.accel(self.t, self.y, self.params.n_balls, self._P, self._S, qdd, self._solver)
        return qdd

    def accelerations_along(self, ys: np.ndarray, steps) -> np.ndarray:
        """Return q'' at each state ``ys[j]`` of step ``steps[j]``, shape (len(ys), N).

        The same values as :meth:`accelerations` at each of those states in turn (the
        spindle command is the present one), in one compiled call.
        """
        qdd = np.empty((len(ys), self.N))
        self.kern.accel_rows(ys, self.t0, self.dt, np.asarray(steps, dtype=np.int64),
                             self.params.n_balls, self._P, self._S, qdd, self._solver)
        return qdd

    @property
    def N(self) -> int:
        """Coordinates N = 7 + n."""
        return self.layout.N

    @property
    def refined_steps(self) -> int:
        """Steps integrated in contact sub-steps since the last parameter change.

        The step is refined automatically while balls touch.
        """
        return int(self._work[W_STATS, STAT_REFINED])

    @property
    def substeps(self) -> int:
        """RK4 sub-steps taken in the refined steps since the last parameter change."""
        return int(self._work[W_STATS, STAT_SUBSTEPS])

    @property
    def rolling_switches(self) -> int:
        """Rolling-resistance regime switches located inside steps since the last change.

        Stick, slip and break-free (event-located Coulomb switching), since the last parameter
        change.
        """
        return int(self._work[W_STATS, STAT_SWITCHES])

    @property
    def max_substeps(self) -> int:
        """Most sub-steps taken in one step since the last parameter change (1: none)."""
        return max(1, int(self._work[W_STATS, STAT_MOST_SUBSTEPS]))

    @property
    def theta(self) -> float:
        """Rotor angle theta [rad]."""
        return float(self.layout.theta(self.y))

    @property
    def omega(self) -> float:
        """Spindle speed theta' [rad/s]."""
        return float(self.layout.omega(self.y))

    @property
    def deck(self) -> np.ndarray:
        """[X, Y, Z, alpha, beta, gamma] (m, rad)."""
        return self.layout.deck(self.y).copy()

    @property
    def deck_rates(self) -> np.ndarray:
        """Deck rates [X', Y', Z', alpha', beta', gamma'] (m/s, rad/s)."""
        return self.layout.deck_rates(self.y).copy()

    @property
    def phi(self) -> np.ndarray:
        """Ball angles phi_i [rad] relative to the rotor."""
        return self.layout.phi(self.y).copy()

    @property
    def phi_rates(self) -> np.ndarray:
        """Ball rates phi_i' [rad/s] relative to the rotor."""
        return self.layout.phi_rates(self.y).copy()

    @property
    def rbar(self) -> float:
        """Deck translation over race radius, sqrt(X^2 + Y^2 + Z^2) / R."""
        return float(self.layout.rbar(self.y, self.params.R))

from abb_ros.model.dynamics import integrators  # noqa: E402 (it imports this module)

INTEGRATORS = {'rk4': integrators.FixedStep, 'adaptive': integrators.Adaptive}
"""The integrators of :class:`Simulation` by name: ``rk4``, the fixed step of ``dt`` (the live
node's, byte for byte), and ``adaptive``, Dormand-Prince 5(4) with error control, sampled by
its dense output at the same instants (:mod:`abb_ros.model.dynamics.kernels.adaptive`). Each
takes the same three calls (advance, advance with q'', trajectory) on a Simulation's state."""
