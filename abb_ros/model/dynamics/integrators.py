"""The integrators of :class:`~abb_ros.model.dynamics.integrate.Simulation`, by name.

Each takes the same three calls (advance, advance with q'', trajectory) on a Simulation's state;
:data:`abb_ros.model.dynamics.integrate.INTEGRATORS` maps the names to them.
"""

from __future__ import annotations

import numpy as np

from abb_ros.model.dynamics import integrate
from abb_ros.model.dynamics.kernels.adaptive import AdaptiveState


class FixedStep:
    """The ``rk4`` integrator: classical RK4 steps of ``dt``, the live node's byte for byte.

    The paper's own compiled stepping while only its terms act (:meth:`Simulation.on_paper`).
    """

    @staticmethod
    def advance(sim, nsteps: int) -> None:
        """Take nsteps steps (:meth:`Simulation.advance`)."""
        advance = sim.kern.paper_advance if sim.on_paper() else sim.kern.advance
        sim._check(*advance(sim.y, sim.t0, sim.dt, sim.steps, nsteps, sim._P, sim._S,
                            sim._work))

    @staticmethod
    def advance_accelerations(sim, nsteps: int, qdd: np.ndarray) -> None:
        """Take nsteps steps, then q'' into ``qdd`` (:meth:`Simulation.advance_accelerations`)."""
        advance_accel = (sim.kern.paper_advance_accel if sim.on_paper()
                         else sim.kern.advance_accel)
        sim._check(*advance_accel(sim.y, sim.t0, sim.dt, sim.steps, nsteps, sim._P, sim._S,
                                  sim._work, qdd))

    @staticmethod
    def trajectory(sim, nsteps: int, every: int, out: np.ndarray) -> int:
        """Store the state every ``every`` of nsteps steps in ``out``; return the rows."""
        done, got, status = sim.kern.trajectory(sim.y, sim.t0, sim.dt, sim.steps, nsteps,
                                                every, sim._P, sim._S, sim._work, out)
        sim._check(done, status)
        return int(got)


class Adaptive:
    """The ``adaptive`` integrator: Dormand-Prince 5(4) with error control.

    Sampled by its dense output at the fixed step's instants (:mod:`~.kernels.adaptive`).
    """

    @staticmethod
    def advance(sim, nsteps: int) -> None:
        """Integrate over nsteps steps of ``dt`` (:meth:`Simulation.advance`)."""
        if nsteps > 0:
            Adaptive.trajectory(sim, nsteps, nsteps, np.empty((1, sim.y.size)))

    @staticmethod
    def advance_accelerations(sim, nsteps: int, qdd: np.ndarray) -> None:
        """Integrate over nsteps steps, then q'' into ``qdd``."""
        Adaptive.advance(sim, nsteps)
        qdd[:] = sim.accelerations()

    @staticmethod
    def trajectory(sim, nsteps: int, every: int, out: np.ndarray) -> int:
        """Sample the state every ``every`` of nsteps steps into ``out``; return the rows."""
        done, got, status = sim.kern.adaptive_trajectory(
            sim.y, sim.t0, sim.dt, sim.steps, nsteps, every, sim._P, sim._S,
            AdaptiveState(integrate.ADAPTIVE_RTOL, sim._atol, sim._ad, sim._aw), out)
        sim._check(done, status)
        return int(got)
