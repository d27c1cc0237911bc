"""Compiled kernels of the nonlinear model, each with a pure-Python twin.

One source, two builds (:mod:`abb_ros.model.jit`): the functions of this package are plain
Python, marked as kernels of the one set :data:`abb_ros.model.dynamics.kernels.layout.kernel`;
``JIT`` holds them compiled with numba (cached on disk) and ``PY`` as they are (plain Python
on numpy arrays). Both run the same statements, so they agree bit for bit; ``PY`` is the
fallback where numba is unavailable (set ``ABB_ROS_NO_JIT=1`` to force it).

Modules, by what they model:

- :mod:`~abb_ros.model.dynamics.kernels.layout`: the packed inputs P, S, the work buffers and the
  scratch tuples, every index named;
- :mod:`~abb_ros.model.dynamics.kernels.eom`: the rows of Eqs. (18)-(24) and their solution;
- :mod:`~abb_ros.model.dynamics.kernels.spindle`: theta'' of a speed profile, the motor's torque;
- :mod:`~abb_ros.model.dynamics.kernels.torque`: theta free (torque mode), its row;
- :mod:`~abb_ros.model.dynamics.kernels.ball_size`: rolling balls' spin inertia;
- :mod:`~abb_ros.model.dynamics.kernels.contact`: the Hertz contact force between balls;
- :mod:`~abb_ros.model.dynamics.kernels.contact_steps`: the sub-steps that resolve a contact;
- :mod:`~abb_ros.model.dynamics.kernels.rolling_resistance`: rolling resistance with stick;
- :mod:`~abb_ros.model.dynamics.kernels.rhs`: q'' and y' at (t, y);
- :mod:`~abb_ros.model.dynamics.kernels.rk4`: the RK4 step;
- :mod:`~abb_ros.model.dynamics.kernels.rolling_events`: rolling switches located within a step;
- :mod:`~abb_ros.model.dynamics.kernels.multirate`,
  :mod:`~abb_ros.model.dynamics.kernels.multirate_fast`: the multirate contact step;
- :mod:`~abb_ros.model.dynamics.kernels.stepper`: one step, many steps (``advance``,
  ``trajectory``).
"""

from __future__ import annotations

from abb_ros.model.dynamics.kernels import stepper  # noqa: F401 (imports, so registers, every kernel)
from abb_ros.model.dynamics.kernels.ball_size import SPIN_INERTIA
from abb_ros.model.dynamics.kernels.contact_steps import (
    CONTACT_IMPACT_SPEED,
    CONTACT_OMEGA_H,
    CONTACT_OMEGA_H_REST,
    CONTACT_RELAX_MAX,
    CONTACT_REST_IMBALANCE,
    MAX_SUBSTEPS,
    MIS_IMPACT_REFINE,
)
from abb_ros.model.dynamics.kernels.layout import (
    ENVELOPE,
    MAX_ANGLE,
    MAX_BALL_RATE,
    MAX_TRANSLATION,
    N_PARAMS,
    N_SPINDLE,
    N_SPINDLE_TORQUE,
    NONFINITE,
    OK,
    PARAM_ORDER,
    SPINDLE_CONSTANT,
    SPINDLE_MOTOR,
    SPINDLE_RAMP,
    SPINDLE_TORQUE,
    Solver,
    Stages,
    kernel,
    make_work,
    pack_params,
    solver_scratch,
    stage_buffers,
)
from abb_ros.model.dynamics.kernels.rolling_events import MAX_SWITCHES
from abb_ros.model.dynamics.kernels.rolling_resistance import STICK_TIME

__all__ = ['JIT', 'PY', 'PARAM_ORDER', 'N_PARAMS', 'N_SPINDLE', 'N_SPINDLE_TORQUE',
           'SPINDLE_CONSTANT', 'SPINDLE_MOTOR', 'SPINDLE_RAMP', 'SPINDLE_TORQUE', 'OK',
           'NONFINITE', 'ENVELOPE', 'MAX_TRANSLATION', 'MAX_ANGLE', 'MAX_BALL_RATE',
           'SPIN_INERTIA', 'STICK_TIME', 'MAX_SWITCHES', 'MAX_SUBSTEPS', 'CONTACT_OMEGA_H',
           'CONTACT_OMEGA_H_REST', 'CONTACT_IMPACT_SPEED', 'CONTACT_RELAX_MAX',
           'CONTACT_REST_IMBALANCE', 'MIS_IMPACT_REFINE', 'Solver', 'Stages', 'make_work',
           'pack_params', 'solver_scratch', 'stage_buffers']

JIT, PY = kernel.build()
"""JIT: compiled kernels (numba), or the Python twin where numba is unavailable; PY: the
pure-Python twin of every kernel, the same source run by the interpreter."""
