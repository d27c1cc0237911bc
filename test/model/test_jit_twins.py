"""Kernels built twice (model/jit.py): compiled and pure-Python twins agree bit for bit."""

import numpy as np
import pytest

from abb_ros.model import jit
from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.equations import accelerations, lagrange_residual
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.kernels.layout import STAT_SWITCHES, W_STATS
from abb_ros.model.dynamics.spindle import SpindleMotor
from abb_ros.model.dynamics.state import StateLayout
from abb_ros.model.parameters.params import METAL_C, DriveParams, apply_settings

needs_numba = pytest.mark.skipif(not kernels.JIT.compiled, reason='numba not available')


def random_state(n, seed):
    """Return (params, omega, y): a drive of n balls at wbar 2.7, its state disturbed at random."""
    params, omega = apply_settings(DriveParams(n=n), {'mbar': 0.03, 'c': METAL_C, 'wbar': 2.7})
    rng = np.random.default_rng(seed)
    y = initial_state(params, omega, phi0=rng.uniform(-np.pi, np.pi, n))
    s = StateLayout(n)
    y[s.deck_slice] += rng.normal(0, 1e-4, 6)
    y[s.deck_rate_slice] = rng.normal(0, 0.05, 6)
    y[s.phi_rate_slice] = rng.normal(0, 5.0, n)
    return params, omega, y


@needs_numba
@pytest.mark.parametrize('n', [0, 2, 10])
def test_compiled_and_python_accelerations_agree(n):
    """The compiled and the interpreted accelerations are equal bit for bit at random states of
    0, 2 and 10 balls with a speed-controlled spindle."""
    params, omega, y = random_state(n, seed=n)
    S = SpindleMotor(max_accel=800.0, tau=0.05).pack(omega * 1.1)
    fast = accelerations(params, y, 0.0, S, kern=kernels.JIT)
    slow = accelerations(params, y, 0.0, S, kern=kernels.PY)
    np.testing.assert_array_equal(fast, slow)          # the same operations in the same order


@needs_numba
def test_compiled_and_python_rk4_agree_over_many_steps():
    """200 compiled RK4 steps and 200 interpreted ones end in the same state bit for bit."""
    params, omega, y0 = random_state(2, seed=7)
    S = SpindleMotor().pack(omega)
    outs = []
    for kern in (kernels.JIT, kernels.PY):
        y = y0.copy()
        done, status = kern.advance(y, 0.0, 1e-4, 0, 200, kernels.pack_params(params), S,
                                    kernels.make_work(2))
        assert (done, status) == (200, kernels.OK)
        outs.append(y)
    np.testing.assert_array_equal(outs[0], outs[1])


@needs_numba
@pytest.mark.parametrize('n', [1, 2, 5])
def test_accelerations_solve_the_equations_of_motion(n):
    """The elimination of the ball accelerations is exact: q'' satisfies all 6 + n equations."""
    params, omega, y = random_state(n, seed=10 + n)
    S = SpindleMotor(max_accel=1500.0, tau=0.02).pack(0.0)   # spinning down: theta'' != 0
    qdd = accelerations(params, y, 0.0, S)
    assert qdd[0] == -1500.0
    res = lagrange_residual(params, y, qdd)
    scale = params.M * params.eps * omega ** 2      # the imbalance force [N]
    assert np.abs(res).max() < 1e-12 * scale


@needs_numba
def test_bad_state_stops_integration_and_keeps_last_good_state():
    """A step that would leave the state envelope is not taken: advance reports ENVELOPE after 0
    steps and the state is the last good one."""
    params, omega, y = random_state(2, seed=3)
    s = StateLayout(2)
    y[s.translation_slice.start] = 0.5 * kernels.MAX_TRANSLATION
    y[s.deck_rate_slice.start] = 1e9        # X' absurd: the next step leaves the envelope
    y_before = y.copy()
    done, status = kernels.JIT.advance(y, 0.0, 1e-4, 0, 10, kernels.pack_params(params),
                                       np.zeros(kernels.N_SPINDLE), kernels.make_work(2))
    assert status == kernels.ENVELOPE and done == 0
    np.testing.assert_array_equal(y, y_before)
    y[2] = np.nan
    done, status = kernels.JIT.advance(y, 0.0, 1e-4, 0, 10, kernels.pack_params(params),
                                       np.zeros(kernels.N_SPINDLE), kernels.make_work(2))
    assert status == kernels.NONFINITE


@needs_numba
def test_compiled_and_python_rk4_agree_across_located_rolling_switches():
    """Rolling resistance: with one ball thrown at 30 rad/s the balls change between slip and stick
    within these 30 ms, so switches are located inside steps; both builds locate the same number
    and end in the same state.
    """
    params = apply_settings(DriveParams(n=2), {'mbar': 0.03, 'c': METAL_C, 'wbar': 2.7})[0]
    params = params.replace(r_ball=2.873e-3, rolling_mu=1e-6, ball_rotation=1)
    omega = 2.7 * params.omega0
    y0 = initial_state(params, omega, phi0=np.radians([30.0, 53.0]))
    y0[9 + 7] = 30.0
    S = SpindleMotor().pack(omega)
    outs, switches = [], []
    for kern in (kernels.JIT, kernels.PY):
        y, work = y0.copy(), kernels.make_work(2)
        done, status = kern.advance(y, 0.0, 1e-4, 0, 300, kernels.pack_params(params), S, work)
        assert (done, status) == (300, kernels.OK)
        outs.append(y)
        switches.append(work[W_STATS, STAT_SWITCHES])
    assert switches[0] == switches[1] > 0
    np.testing.assert_array_equal(outs[0], outs[1])


def test_kernel_set_builds_a_compiled_and_a_python_namespace_of_the_same_functions():
    """A KernelSet's build gives the same functions twice, compiled (a kernel calling another gets
    the compiled one) and interpreted, with equal results."""
    kernel = jit.KernelSet(error_model='numpy')

    @kernel
    def twice(x):
        return 2.0 * x

    @kernel
    def four_times(x):
        return twice(twice(x))   # a kernel calling a kernel

    JIT, PY = kernel.build()
    assert PY.four_times is four_times and not PY.compiled and PY.names == ('twice', 'four_times')
    assert JIT.four_times(1.5) == PY.four_times(1.5) == 6.0
    assert JIT.compiled == jit.enabled()


def test_an_inlined_kernel_is_compiled_into_its_caller_and_stays_a_kernel():
    """A kernel marked inline gives the same results in both builds and can still be called on its
    own."""
    kernel = jit.KernelSet(error_model='numpy')

    @kernel(inline=True)
    def thrice(x):
        return 3.0 * x

    @kernel
    def nine_times(x):
        return thrice(thrice(x))

    JIT, PY = kernel.build()
    assert JIT.nine_times(1.5) == PY.nine_times(1.5) == JIT.thrice(4.5) == 13.5


def test_every_kernel_is_in_both_builds_and_takes_at_most_ten_arguments():
    """The package registers each kernel once; none has a long positional list."""
    import inspect
    assert kernels.JIT.names == kernels.PY.names and len(kernels.PY.names) > 50
    widest = max(len(inspect.signature(getattr(kernels.PY, name)).parameters)
                 for name in kernels.PY.names)
    assert widest <= 10
