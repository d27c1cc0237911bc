"""The kernels compile by set, and only what changed is compiled again.

A node on the paper's path steps with the paper's own compiled entry points (a fraction of the
general stepping's compile time): they must give the general stepping's numbers bit for bit. The
warm-up gives each compiled entry point a key over the sources its module imports: editing a
module deletes the cached machine code of the entry points that import it, and only theirs.
"""

import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from abb_ros.model import jit, warmup
from abb_ros.model.dynamics import kernels
from abb_ros.model.dynamics.integrate import DEFAULT_DT, Simulation
from abb_ros.model.dynamics.spindle import SpindleMotor, TorqueMotor
from abb_ros.model.parameters.params import DriveParams

ROOT = Path(__file__).resolve().parents[2]
KERNELS = ROOT / 'abb_ros' / 'model' / 'dynamics' / 'kernels'
STEPS = 3000   # 0.3 s of a spin-up at 10 kHz: every term of Eqs. (18)-(24) at work


@pytest.mark.parametrize('offsets', [{}, {'z_P': 0.004, 'z_G': 0.001, 'z_B': -0.0005,
                                          'tau': 0.002, 'psi_tau': 0.5}],
                         ids=['plane', 'offsets'])
@pytest.mark.parametrize('kern', [kernels.JIT, kernels.PY], ids=['compiled', 'python'])
def test_paper_stepping_gives_the_general_stepping_bit_for_bit(kern, offsets):
    """The paper's stepping, which also carries heights and a leaning axis (F4, F6), takes the
    general stepping's steps bit for bit."""
    params = DriveParams(**offsets)
    omega = 2.7 * params.omega0
    steps = STEPS if kern.compiled else 200
    sim = Simulation(params, omega, DEFAULT_DT, spindle=SpindleMotor(2000.0, 0.05))
    assert sim.on_paper()
    y = sim.y.copy()
    qdd_paper, qdd_general = np.empty(sim.N), np.empty(sim.N)
    done_p, status_p = kern.paper_advance_accel(sim.y, sim.t0, sim.dt, 0, steps,
                                                kernels.pack_params(params),
                                                sim.spindle.pack(omega),
                                                kernels.make_work(params.n), qdd_paper)
    done_g, status_g = kern.advance_accel(y, sim.t0, sim.dt, 0, steps,
                                          kernels.pack_params(params), sim.spindle.pack(omega),
                                          kernels.make_work(params.n), qdd_general)
    assert (done_p, status_p) == (done_g, status_g) == (steps, kernels.OK)
    assert np.array_equal(sim.y, y)
    assert np.array_equal(qdd_paper, qdd_general)


def test_a_torque_driven_spindle_leaves_the_paper_path():
    sim = Simulation(DriveParams(), 811.2, DEFAULT_DT, spindle=TorqueMotor())
    assert not sim.on_paper()


def test_a_stepper_module_closure_holds_the_contact_kernels_and_the_imu_one_does_not():
    stepper = warmup.module_closure(KERNELS / 'stepper.py')
    imu = warmup.module_closure(ROOT / 'abb_ros' / 'model' / 'sensors' / 'imu.py')
    assert KERNELS / 'contact.py' in stepper and KERNELS / 'rk4.py' in stepper
    assert KERNELS / 'contact.py' not in imu


REFRESH = textwrap.dedent('''
    import sys
    sys.path.insert(0, sys.argv[1])
    from abb_ros.model import warmup
    print(warmup.refresh_stale())
    ''')


@pytest.mark.skipif(not jit.enabled(), reason='numba not available')
def test_editing_a_kernel_module_deletes_the_cache_of_the_kernels_that_import_it_only(
        tmp_path):
    """A copy of the package with a cache of its own: stand-in cache files for an entry point
    that imports contact.py (stepper.advance) and one that does not (imu.deck_pose_twist)."""
    shutil.copytree(ROOT / 'abb_ros', tmp_path / 'abb_ros',
                    ignore=shutil.ignore_patterns('__pycache__'))
    env = {'NUMBA_CACHE_DIR': str(tmp_path / 'cache'), 'PATH': '/usr/bin:/bin'}

    def refresh():
        done = subprocess.run([sys.executable, '-c', REFRESH, str(tmp_path)], env=env,
                              capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
        return int(done.stdout)

    refresh()                                # first keys
    copy = tmp_path / 'abb_ros' / 'model'
    caches = {p.parent for p in (tmp_path / 'cache').rglob('*' + warmup.KEY_SUFFIX)}
    kernels_dir = next(c for c in caches if c.name.startswith('kernels_'))
    sensors_dir = next(c for c in caches if c.name.startswith('sensors_'))
    advance = kernels_dir / 'stepper.advance-1.py311.nbi'
    pose = sensors_dir / 'imu.deck_pose_twist-1.py311.nbi'
    for stand_in in (advance, pose):
        stand_in.write_text('stand-in')
    assert refresh() == 0 and advance.exists() and pose.exists()   # nothing changed
    contact = copy / 'dynamics' / 'kernels' / 'contact.py'
    contact.write_text(contact.read_text() + '\n# edited\n')
    assert refresh() == 1
    assert not advance.exists() and pose.exists()


def test_warmup_names_an_unknown_kernel_set_and_the_valid_ones_exit_2():
    done = subprocess.run([sys.executable, '-m', 'abb_ros.model.warmup', '--sets', 'gnrl'],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert done.stderr.strip() == ('warmup: --sets: gnrl is not a kernel set; valid: '
                                   f'{", ".join(warmup.KERNEL_SETS)} (comma-separated)')
