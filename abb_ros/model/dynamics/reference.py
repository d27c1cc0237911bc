"""The reference integration: the same right-hand side by scipy's adaptive ``solve_ivp``.

The fixed-step RK4 of :class:`abb_ros.model.dynamics.integrate.Simulation` is checked against
it (docs/verification.md): DOP853 at rtol 1e-10, atol 1e-13 by default.
"""

from __future__ import annotations

import numpy as np

from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.equations import solver_buffers
from abb_ros.model.dynamics.spindle import ConstantSpeed
from abb_ros.model.dynamics.state import StateLayout
from abb_ros.model.parameters.params import DriveParams

__all__ = ['reference_solution']


def reference_solution(params: DriveParams, y0, t_span, spindle=None, t_eval=None,
                       rtol: float = 1e-10, atol: float = 1e-13, method: str = 'DOP853',
                       kern=None):
    """Integrate the same equations by scipy's adaptive ``solve_ivp``; return its OdeResult.

    Default DOP853, tight tolerances; the right-hand side from ``kern`` (default the compiled
    kernels).
    """
    from scipy.integrate import solve_ivp
    n = params.n_balls
    layout = StateLayout(n)
    P = kernels.pack_params(params)
    S = (spindle or ConstantSpeed()).pack(float(layout.omega(y0)))
    kern = kern or kernels.JIT
    bufs = solver_buffers(n)

    def fun(t, y):
        dy = np.empty(layout.size)
        kern.deriv(t, np.ascontiguousarray(y), n, P, S, dy, bufs)
        return dy

    return solve_ivp(fun, t_span, np.asarray(y0, dtype=float), method=method, rtol=rtol,
                     atol=atol, t_eval=t_eval)
