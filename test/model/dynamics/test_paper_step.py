"""The paper's path of the integrator (kernels/stepper.paper_step): where only Eqs. (18)-(24)
act, each RK4 step is one call with everything compiled in place (numba then drops the
reference counting of its arrays). It must take exactly the steps of the general step."""

import numpy as np
import pytest
from test_jit_twins import random_state

from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.kernels.layout import W_CACHE, solver_scratch, work_stages
from abb_ros.model.dynamics.spindle import SpindleMotor, TorqueMotor
from abb_ros.model.parameters.params import DriveParams

PY = kernels.PY


@pytest.mark.parametrize('n', [0, 2, 10])
def test_the_paper_path_takes_the_general_steps_bit_for_bit(n):
    """120 steps of a spinning-up drive (theta'' != 0) by ``advance`` (the paper's path) and by
    the general ``step`` one at a time end in the same state, bit for bit."""
    params, omega, y0 = random_state(n, seed=40 + n)
    P = kernels.pack_params(params)
    S = SpindleMotor(max_accel=900.0, tau=0.05).pack(omega * 1.2)
    assert PY.on_paper(n, P, S)
    y_paper = y0.copy()
    assert PY.advance(y_paper, 0.0, 1e-4, 0, 120, P, S, kernels.make_work(n)) == (120, kernels.OK)
    y, work = y0.copy(), kernels.make_work(n)
    stages, solver = work_stages(work), solver_scratch(n)
    for k in range(120):
        status, sub, switches = PY.step(k * 1e-4, 1e-4, y, n, P, S, stages, solver,
                                        work[W_CACHE:])
        assert (status, sub, switches) == (kernels.OK, 1, 0)
    np.testing.assert_array_equal(y_paper, y)


@pytest.mark.parametrize('change', [
    {'contact_E': 2.0e11, 'r_ball': 2.873e-3},
    {'rolling_mu': 1e-6, 'r_ball': 2.873e-3},
    {'ball_rotation': 1, 'r_ball': 2.873e-3},
])
def test_contact_rolling_and_ball_spin_leave_the_paper_path(change):
    params = DriveParams(n=2).replace(**change)
    assert not PY.on_paper(2, kernels.pack_params(params), SpindleMotor().pack(300.0))


def test_a_free_spindle_leaves_the_paper_path():
    """In torque mode theta'' comes from the motor torque, not from a profile."""
    S = TorqueMotor().pack(0.0)
    assert not PY.on_paper(2, kernels.pack_params(DriveParams(n=2)), S)
    assert PY.on_paper(2, kernels.pack_params(DriveParams(n=2)), SpindleMotor().pack(300.0))
