"""Start-up parameter types of the node executables, over real rclpy and DDS: an integer
literal for a double is taken as the double, other wrong types end the node with exit
code 2 and one line naming the parameter and what is valid."""

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import rclpy
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import GetParameters, SetParameters
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[3]
DEADLINE_S = 30.0
RESEND_S = 2.0
"""A request unanswered this long is sent again (a lost request, not a slow node)."""


def _command(node, params):
    args = [sys.executable, '-m', f'abb_ros.nodes.{node}', '--ros-args']
    for p in params:
        args += ['-p', p]
    return args


def _start_fails(node, *params):
    proc = subprocess.run(_command(node, params), cwd=ROOT, capture_output=True, text=True,
                          timeout=120, stdin=subprocess.DEVNULL)
    return proc.returncode, proc.stderr


@pytest.mark.parametrize('node,param,needle', [
    ('simulator', 'drive.k:=abc',
     "'drive.k' = 'abc' is invalid: valid range is [0.003972, 3.972e+09] N/m"),
    ('simulator', 'drive.n:=2.0', "'drive.n' = 2.0 is invalid: valid range is [0, 64]"),
    ('simulator', 'seed:=[1, 2]', "'seed'"),
    ('simulator', 'imu.position:=[0.0, 1.0]', "'imu.position'"),
    ('simulator', 'drive.k:=-5.0', "'drive.k' = -5.0"),
    ('analysis', 'drive.k:=abc',
     "'drive.k' = 'abc' is invalid: valid range is [0.003972, 3.972e+09] N/m"),
    ('analysis', 'table_points:=300.0', "'table_points' = 300.0"),
    ('simulator', "record.topics:=['bad name']", "'record.topics' = 'bad name' is invalid"),
    ('simulator', "record.topics:=[x//y]", "'record.topics' = 'x//y'"),
    ('simulator', 'record.topics:=[1, 2]', "'record.topics' = [1, 2]"),
    ('recorder', "topics:=['bad name']", "'topics' = 'bad name' is invalid"),
    ('simulator', 'imu.accel_noise_density:=1e200', "'imu.accel_noise_density' = 1e+200"),
    ('simulator', 'fault.imu_accel_bias_step:=[1e308, 1e308, 1e308]',
     "'fault.imu_accel_bias_step'"),
    ('simulator', 'fault.speed_noise:=1e308', "'fault.speed_noise' = 1e+308"),
    ('simulator', 'real_time_factor:=1e-14',
     "'real_time_factor' = 1e-14 is invalid: valid range is 0 (as fast as possible) or "
     '[1e-06, 1000]'),
])
@pytest.mark.slow
def test_wrong_start_up_type_or_value_exits_2_with_one_line_naming_it(node, param, needle):
    code, err = _start_fails(node, param)
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert needle in lines[0] and 'Traceback' not in err


@pytest.mark.parametrize('node', ['simulator', 'analysis', 'recorder', 'spin_controller'])
def test_unparsable_ros_args_exit_2_naming_them_without_a_traceback(node):
    """rcl cannot parse the override (its own error line comes first, from rcl's logger)."""
    code, err = _start_fails(node, 'record.topics:=[unclosed')
    assert code == 2, err
    assert 'Traceback' not in err
    assert err.strip().splitlines()[-1].endswith(
        "invalid --ros-args: failed to initialize rcl: Couldn't parse parameter override "
        "rule: '-p record.topics:=[unclosed'. Error: Error parsing an event")


class _Client:
    def __init__(self):
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        self.node = Node('test_parameter_client', context=self.ctx)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)

    def call(self, kind, name, request):
        """Call ``name`` once it is up; resend a request whose reply is lost.

        A request sent just as the service is discovered can go unanswered (the server has
        not matched the reply's reader yet); get and set are idempotent, so it is sent again
        every RESEND_S. The node's start-up and the reply each have DEADLINE_S.
        """
        client = self.node.create_client(kind, name)
        deadline = time.monotonic() + DEADLINE_S
        while not client.service_is_ready():
            assert time.monotonic() < deadline, \
                f'timed out after {DEADLINE_S} s: no service {name}'
            self.executor.spin_once(timeout_sec=0.05)
        deadline = time.monotonic() + DEADLINE_S
        while True:
            future = client.call_async(request)
            resend = time.monotonic() + RESEND_S
            while not future.done() and time.monotonic() < resend:
                assert time.monotonic() < deadline, \
                    f'timed out after {DEADLINE_S} s: no reply from {name}'
                self.executor.spin_once(timeout_sec=0.05)
            if future.done():
                return future.result()
            client.remove_pending_request(future)

    def get(self, node, name):
        return self.call(GetParameters, f'/{node}/get_parameters',
                         GetParameters.Request(names=[name])).values[0]

    def set(self, node, name, value):
        request = SetParameters.Request(parameters=[Parameter(name, value=value)
                                                    .to_parameter_msg()])
        return self.call(SetParameters, f'/{node}/set_parameters', request).results[0]

    def close(self):
        self.node.destroy_node()
        rclpy.shutdown(context=self.ctx)


@pytest.fixture
def client():
    c = _Client()
    yield c
    c.close()


@pytest.mark.slow
@pytest.mark.parametrize('node,name', [('simulator', 'abb_simulator'),
                                       ('analysis', 'abb_analysis')])
def test_integer_literal_for_a_double_parameter_is_accepted(client, tmp_path, node, name):
    log = open(tmp_path / 'node.log', 'w')
    proc = subprocess.Popen(_command(node, ['drive.k:=4000', 'real_time_factor:=0.0']
                                     if node == 'simulator' else ['drive.k:=4000']),
                            cwd=ROOT, stdout=log, stderr=subprocess.STDOUT,
                            stdin=subprocess.DEVNULL)
    try:
        k = client.get(name, 'drive.k')
        assert k.type == ParameterType.PARAMETER_DOUBLE and k.double_value == 4000.0
        # at run time too: an integer for a double is set as the double
        result = client.set(name, 'drive.k', 5000)
        assert result.successful, result.reason
        k = client.get(name, 'drive.k')
        assert k.type == ParameterType.PARAMETER_DOUBLE and k.double_value == 5000.0
        # a string is refused, the value stays
        assert not client.set(name, 'drive.k', 'abc').successful
        assert client.get(name, 'drive.k').double_value == 5000.0
    finally:
        proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=30)
        log.close()
    assert code == 0, (tmp_path / 'node.log').read_text()


@pytest.mark.slow
def test_values_that_would_overflow_the_plant_are_refused_at_run_time(client, tmp_path):
    """``ros2 param set`` of a value that once killed or poisoned the plant: refused with a
    reason naming the parameter (rclpy's range check or the spec's), and the node lives on."""
    log = open(tmp_path / 'node.log', 'w')
    proc = subprocess.Popen(_command('simulator', ['real_time_factor:=0.0']), cwd=ROOT,
                            stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    try:
        for name, value in (('imu.accel_noise_density', 1e200),
                            ('imu.gyro_noise_density', 1e200),
                            ('fault.imu_accel_bias_step', [1e308] * 3),
                            ('fault.speed_noise', 1e308)):
            result = client.set('abb_simulator', name, value)
            assert not result.successful and name in result.reason, result.reason
        assert client.set('abb_simulator', 'fault.speed_noise', 1.0).successful
        assert proc.poll() is None, (tmp_path / 'node.log').read_text()
    finally:
        proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=30)
        log.close()
    assert code == 0, (tmp_path / 'node.log').read_text()
