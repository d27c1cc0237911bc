"""The package installs the way ``colcon build`` and ``ros2 run abb_ros <exe>`` expect.

The checkout is built once per module with colcon (no symlink install) into a temporary prefix.
The tests then check the ament layout, resolve the package through ament_index_python in the
environment that the generated ``install/setup.sh`` produces (what ``ros2 run`` sees), and run
the installed ``simulator`` over DDS with the installed Table 1 parameter file.
"""

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PACKAGE = 'abb_ros'
EXECUTABLES = ('simulator', 'analysis', 'recorder', 'spin_controller', 'warmup')
# Table 1 drive of config/cdrom_table1.yaml has n = 2 balls.
TABLE1_JOINTS = ['spindle', 'ball_1', 'ball_2']

# Timeouts are upper bounds for a loaded 2-core CI machine, not expectations: the build takes
# about 2 s here; the first message may wait for the model's compiled kernel on a cold cache.
COLCON_TIMEOUT_S = 300.0
FIRST_MESSAGE_TIMEOUT_S = 90.0
SHUTDOWN_TIMEOUT_S = 20.0
# A node may publish once while it starts; several messages show that its timer runs in spin(),
# which is where the SIGINT below must find it.
MIN_MESSAGES = 3

pytestmark = pytest.mark.slow


def _colcon_executable() -> str:
    """The colcon next to this interpreter (the venv's), else the one on PATH (system ROS)."""
    beside = Path(sys.executable).with_name('colcon')
    if beside.exists():
        return str(beside)
    found = shutil.which('colcon')
    if found is None:
        pytest.fail('colcon not found: it is pinned in requirements.txt (colcon-core, colcon-ros)')
    return found


@pytest.fixture(scope='module')
def install(tmp_path_factory) -> Path:
    """Install prefix of ``colcon build --paths <repo>`` (isolated layout: <prefix>/abb_ros)."""
    base = tmp_path_factory.mktemp('colcon')
    env = dict(os.environ, COLCON_HOME=str(base / 'colcon_home'))  # ignore the user's defaults
    cmd = [
        _colcon_executable(), '--log-base', str(base / 'log'),
        'build', '--paths', str(REPO),
        '--build-base', str(base / 'build'), '--install-base', str(base / 'install'),
    ]
    result = subprocess.run(cmd, cwd=base, env=env, stdin=subprocess.DEVNULL,
                            capture_output=True, text=True, timeout=COLCON_TIMEOUT_S)
    assert result.returncode == 0, f'colcon build failed:\n{result.stdout}\n{result.stderr}'
    return base / 'install'


@pytest.fixture(scope='module')
def sourced_env(install) -> dict:
    """``os.environ`` after ``. install/setup.sh`` (the sh variant colcon-core always writes)."""
    script = '. "$ABB_ROS_TEST_PREFIX/setup.sh" && env -0'
    env = dict(os.environ, ABB_ROS_TEST_PREFIX=str(install))
    out = subprocess.run(['sh', '-c', script], env=env, stdin=subprocess.DEVNULL,
                         capture_output=True, check=True).stdout
    env = dict(item.split('=', 1) for item in out.decode().split('\0') if '=' in item)
    env.pop('ABB_ROS_TEST_PREFIX', None)
    return env


def test_colcon_installs_the_console_scripts_where_ros2_run_looks(install):
    lib = install / PACKAGE / 'lib' / PACKAGE
    for name in EXECUTABLES:
        path = lib / name
        installed = sorted(p.name for p in lib.iterdir())
        assert path.is_file(), f'{path} missing; installed: {installed}'
        assert os.access(path, os.X_OK), f'{path} is not executable'


def test_colcon_installs_the_ament_marker_manifest_and_table1_parameters(install):
    prefix = install / PACKAGE
    marker = prefix / 'share' / 'ament_index' / 'resource_index' / 'packages' / PACKAGE
    assert marker.is_file()
    share = prefix / 'share' / PACKAGE
    # Installed copies, byte for byte: the share directory is what users pass to --params-file.
    assert (share / 'package.xml').read_bytes() == (REPO / 'package.xml').read_bytes()
    assert (share / 'config' / 'cdrom_table1.yaml').read_bytes() == \
        (REPO / 'config' / 'cdrom_table1.yaml').read_bytes()


def test_colcon_installs_the_bench_launch_file_where_ros2_launch_looks(install):
    # ros2 launch <pkg> <file> searches <share>/<pkg> recursively; launch/ is the convention.
    installed = install / PACKAGE / 'share' / PACKAGE / 'launch' / 'bench.launch.py'
    assert installed.read_bytes() == (REPO / 'launch' / 'bench.launch.py').read_bytes()


def test_colcon_installs_the_foxglove_layout_and_ros2_control_files_beside_the_parameters(
        install):
    share = install / PACKAGE / 'share' / PACKAGE
    assert (share / 'config' / 'foxglove_layout.json').read_bytes() == \
        (REPO / 'config' / 'foxglove_layout.json').read_bytes()
    for name in ('abb_spindle.urdf.xacro', 'abb_controllers.yaml'):   # ros2_control's files
        assert (share / 'config' / 'ros2_control' / name).read_bytes() == \
            (REPO / 'config' / 'ros2_control' / name).read_bytes()


# Run in the sourced environment, as `ros2 run` would: ros2pkg's get_executable_paths() lists
# the executable files under <get_package_prefix(pkg)>/lib/<pkg>.
_RESOLVE = """
import json, os, sys
from ament_index_python.packages import get_package_prefix, get_package_share_directory
import abb_ros
prefix = get_package_prefix('abb_ros')
lib = os.path.join(prefix, 'lib', 'abb_ros')
print(json.dumps({
    'prefix': prefix,
    'share': get_package_share_directory('abb_ros'),
    'executables': sorted(n for n in os.listdir(lib) if os.access(os.path.join(lib, n), os.X_OK)),
    'module': abb_ros.__file__,
}))
"""


def test_ament_index_resolves_the_installed_package_as_ros2_run_does(install, sourced_env):
    prefix = install / PACKAGE
    assert str(prefix) in sourced_env['AMENT_PREFIX_PATH'].split(os.pathsep)
    out = subprocess.run([sys.executable, '-c', _RESOLVE], env=sourced_env, cwd=install,
                         stdin=subprocess.DEVNULL, capture_output=True, text=True, check=True)
    found = json.loads(out.stdout)
    assert Path(found['prefix']) == prefix
    assert Path(found['share']) == prefix / 'share' / PACKAGE
    assert set(EXECUTABLES) <= set(found['executables'])
    # The installed copy shadows the editable checkout, so the executables run installed code.
    assert Path(found['module']).resolve().is_relative_to(prefix.resolve()), found['module']


WARMUP_TIMEOUT_S = 900.0   # a cold compile of every kernel on a loaded machine


def test_installed_warmup_compiles_the_kernels_into_the_install_tree(install, sourced_env):
    """The colcon route's set-up step (`ros2 run abb_ros warmup`): numba's cache of the
    installed sources lands beside them, in the install tree."""
    prefix = install / PACKAGE
    result = subprocess.run([str(prefix / 'lib' / PACKAGE / 'warmup'), '--sets', 'simulator'],
                            env=sourced_env,
                            stdin=subprocess.DEVNULL, capture_output=True, text=True,
                            timeout=WARMUP_TIMEOUT_S)
    assert result.returncode == 0, result.stdout + result.stderr
    cache = Path(result.stdout.rsplit('cache: ', 1)[1].strip())
    assert cache.resolve().is_relative_to(prefix.resolve()), cache
    assert list(cache.glob('*.nbi')) and list(cache.glob('*.nbc')), cache


@pytest.mark.ros
def test_installed_simulator_publishes_joint_states_and_stops_cleanly_on_sigint(
        install, sourced_env, tmp_path):
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import JointState

    prefix = install / PACKAGE
    params = prefix / 'share' / PACKAGE / 'config' / 'cdrom_table1.yaml'
    # A namespace of its own: topic names are relative, and no other run can answer.
    namespace = f'/layout_{uuid.uuid4().hex[:8]}'
    log_path = tmp_path / 'simulator.log'
    received = []

    context = rclpy.Context()
    rclpy.init(context=context)
    node = executor = proc = None
    with open(log_path, 'w+') as log:
        try:
            node = rclpy.create_node('layout_probe', context=context)
            # Best-effort subscriber: QoS-compatible with both reliable and best-effort publishers.
            node.create_subscription(JointState, f'{namespace}/joint_states', received.append,
                                     qos_profile_sensor_data)
            executor = SingleThreadedExecutor(context=context)
            executor.add_node(node)
            proc = subprocess.Popen(
                [str(prefix / 'lib' / PACKAGE / 'simulator'), '--ros-args',
                 '--params-file', str(params), '-r', f'__ns:={namespace}'],
                env=sourced_env, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT)

            deadline = time.monotonic() + FIRST_MESSAGE_TIMEOUT_S
            while (len(received) < MIN_MESSAGES and proc.poll() is None
                   and time.monotonic() < deadline):
                executor.spin_once(timeout_sec=0.1)
            assert proc.poll() is None, f'simulator exited early:\n{_read(log)}'
            assert len(received) >= MIN_MESSAGES, \
                f'{len(received)} joint_states in {FIRST_MESSAGE_TIMEOUT_S} s:\n{_read(log)}'

            proc.send_signal(signal.SIGINT)
            returncode = proc.wait(timeout=SHUTDOWN_TIMEOUT_S)
            output = _read(log)
            assert returncode == 0, f'exit code {returncode} after SIGINT:\n{output}'
            assert 'Traceback' not in output, output
        finally:
            if proc is not None and proc.poll() is None:
                proc.kill()
                proc.wait()
            if executor is not None:
                executor.shutdown()
            if node is not None:
                node.destroy_node()
            rclpy.try_shutdown(context=context)

    for msg in received:
        assert list(msg.name) == TABLE1_JOINTS
        assert len(msg.position) == len(msg.velocity) == len(TABLE1_JOINTS)
        assert all(math.isfinite(v) for v in [*msg.position, *msg.velocity])


def _read(log) -> str:
    log.flush()
    log.seek(0)
    return log.read()
