"""The ball model beyond the paper (ball radius, Hertzian contact, rolling resistance, ball
rotation) through every interface: CLI run, stability, scenarios, and the ROS parameters the
simulator and analysis nodes declare (read from real nodes over DDS)."""

import json
import math
import threading
import time

import numpy as np
import pytest
import rclpy
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import DescribeParameters, GetParameters
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from abb_ros.cli import main
from abb_ros.io.files.scenario import load_scenario
from abb_ros.model.parameters.params import PARAM_SPECS, DriveParams
from abb_ros.nodes.analysis.node import AnalysisNode
from abb_ros.nodes.simulator.node import SimulatorNode, make_executor

STEEL_P1 = ['--set', 'r_ball=2.873e-3', '--set', 'contact_E=2e11', '--set', 'rolling_mu=1e-6',
            '--set', 'ball_rotation=1']


def test_headless_run_takes_the_new_parameters_and_reports_refined_steps(abb_sim):
    """abb-sim run --set r_ball=... on P1: the balls meet within 0.3 s
    (docs/ball_size_contact_rolling.md, P1 figure), so contact sub-steps are reported in the
    summary, with the active terms; the rolling balls stick and slip, so located rolling
    switches are reported too."""
    code, out, err = abb_sim('run', '--scenario', 'p1', '--duration', '0.5', '--json',
                             '--no-progress', *STEEL_P1)
    assert code == 0, err
    summary = json.loads(out)
    assert summary['beyond_paper'] == ['contact', 'rolling_mu', 'ball_rotation']
    assert summary['contact_refined_steps'] > 0 and summary['contact_max_substeps'] > 1
    assert summary['rolling_switches'] > 0


def test_stability_says_which_terms_the_linear_analysis_ignores(capsys):
    code = main(['stability', '--set', 'mbar=0.03', '--set', 'wbar=2.7', '--json', *STEEL_P1])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    assert 'contact, rolling_mu, ball_rotation' in out['note']
    assert out['verdict'] == 'balanced'


def test_stability_of_the_paper_model_has_no_note(capsys):
    code = main(['stability', '--set', 'mbar=0.03', '--set', 'wbar=2.7', '--json'])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    assert out['verdict'] == 'balanced'
    assert 'note' not in out


def test_bad_beyond_paper_value_exits_2_naming_it(abb_sim):
    code, _, err = abb_sim('run', '--scenario', 'p3', '--set', 'rolling_mu=1e-6')
    assert code == 2
    assert "'r_ball'" in err and 'rolling_mu' in err and len(err.strip().splitlines()) == 1


def test_scenario_settings_take_the_new_parameters():
    scenario = load_scenario('p3').with_settings({'r_ball': 2e-3, 'contact_E': 2e11})
    assert scenario.params.beyond_paper == ('contact',)


BALL_MODEL_NAMES = ['r_ball', 'contact_E', 'contact_nu', 'contact_damping', 'rolling_mu',
                    'rolling_stick_rate', 'ball_rotation']
NODE_NAMES = ['abb_simulator', 'abb_analysis']
DEADLINE_S = 30.0   # generous: the machine is shared; a healthy call takes milliseconds


class _DriveNodes:
    """The simulator and analysis nodes spinning in a background thread, and a client node
    that calls their parameter services over DDS (what ``ros2 param describe`` does)."""

    def __init__(self):
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        self.nodes = [SimulatorNode(context=self.ctx), AnalysisNode(context=self.ctx)]
        self.executor = make_executor(self.ctx)
        for node in self.nodes:
            self.executor.add_node(node)
        self.client = Node('test_parameter_client', context=self.ctx)
        self.client_executor = SingleThreadedExecutor(context=self.ctx)
        self.client_executor.add_node(self.client)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self):
        while not self._stop.is_set() and self.ctx.ok():
            self.executor.spin_once(timeout_sec=0.05)

    def call(self, kind, name, request):
        client = self.client.create_client(kind, name)
        deadline = time.monotonic() + DEADLINE_S
        while not client.service_is_ready():
            if time.monotonic() > deadline:
                pytest.fail(f'timed out after {DEADLINE_S} s waiting for service {name}')
            self.client_executor.spin_once(timeout_sec=0.05)
        future = client.call_async(request)
        while not future.done():
            if time.monotonic() > deadline:
                pytest.fail(f'timed out after {DEADLINE_S} s waiting for a reply of {name}')
            self.client_executor.spin_once(timeout_sec=0.05)
        self.client.destroy_client(client)
        return future.result()

    def close(self):
        self._stop.set()
        self._thread.join(timeout=10)
        self.executor.shutdown()
        for node in self.nodes:
            node.destroy_node()
        self.client.destroy_node()
        rclpy.shutdown(context=self.ctx)


@pytest.fixture(scope='module')
def drive_nodes():
    nodes = _DriveNodes()
    yield nodes
    nodes.close()


@pytest.fixture(scope='module')
def declared(drive_nodes):
    """{node name: {ROS name: (descriptor, value)}} of the ball-model parameters, read by the
    nodes' describe_parameters and get_parameters services."""
    names = [f'drive.{name}' for name in BALL_MODEL_NAMES]
    found = {}
    for node in NODE_NAMES:
        described = drive_nodes.call(DescribeParameters, f'/{node}/describe_parameters',
                                     DescribeParameters.Request(names=names)).descriptors
        values = drive_nodes.call(GetParameters, f'/{node}/get_parameters',
                                  GetParameters.Request(names=names)).values
        found[node] = dict(zip(names, zip(described, values)))
    return found


@pytest.mark.ros
@pytest.mark.parametrize('node', NODE_NAMES)
@pytest.mark.parametrize('name', BALL_MODEL_NAMES)
def test_node_parameter_descriptor_matches_the_default_type(declared, node, name):
    """drive.<name> as the running simulator and analysis nodes declare it: the type of
    DriveParams' default (ball_rotation an integer, the others doubles), that default as the
    value, and the spec's bounds as an integer or a floating-point range, never both."""
    spec = PARAM_SPECS[name]
    descriptor, value = declared[node][f'drive.{name}']
    assert descriptor.name == f'drive.{name}'
    default = getattr(DriveParams(), name)
    high = math.inf if spec.high is None else spec.high
    if isinstance(default, int):
        assert descriptor.type == value.type == ParameterType.PARAMETER_INTEGER
        assert value.integer_value == default
        assert not descriptor.floating_point_range
        (bounds,) = descriptor.integer_range
        assert isinstance(bounds.from_value, int)
    else:
        assert descriptor.type == value.type == ParameterType.PARAMETER_DOUBLE
        assert value.double_value == default
        assert not descriptor.integer_range
        (bounds,) = descriptor.floating_point_range
    assert (bounds.from_value, bounds.to_value, bounds.step) == (spec.low, high, 0)
    assert not descriptor.read_only
    assert spec.valid_text() in descriptor.description


def test_overlapping_start_with_contact_exits_2_naming_phi0(abb_sim):
    """p3_n10 starts its ten balls 1 deg apart: with 1.68 mm balls in contact that is an
    overlap, refused with one line naming phi0 and the least separation."""
    code, _, err = abb_sim('run', '--scenario', 'p3_n10', '--set', 'r_ball=1.68e-3',
                           '--set', 'contact_E=2e11', '--duration', '0.1', '--no-progress')
    assert code == 2
    assert "'phi0'" in err and '12.8' in err and len(err.strip().splitlines()) == 1


def test_with_contact_the_default_start_puts_the_balls_side_by_side_just_apart():
    """No start angles given (the simulator node, a scenario without phi_deg): with contact the
    two groups of Section 5's start are spread by the contact separation + 0.1 deg instead of
    1 deg, so ten steel balls start without overlap; without contact the start is the paper's."""
    from abb_ros.model.dynamics.initial import default_phi0, initial_state
    from abb_ros.model.parameters.ball_materials import with_steel_balls
    paper = DriveParams(n=10)
    steel = with_steel_balls(paper)
    phi = np.degrees(initial_state(steel, 500.0)[7:17])
    gaps = np.diff(np.sort(phi))
    assert gaps.min() == pytest.approx(np.degrees(steel.contact_separation) + 0.1)
    assert phi[:2] == pytest.approx([60.0, -60.0])
    assert np.array_equal(initial_state(paper, 500.0)[7:17], default_phi0(10))
    assert np.degrees(default_phi0(4)).round(12).tolist() == [60.0, -60.0, 61.0, -61.0]
