"""Stepping through simulation_interfaces is deterministic and equals the headless run.

Two simulator nodes, each in its own Context, run scenario P3 from the same seed and are driven
by the same sequence of StepSimulation and SimulateSteps calls (a cancel-free goal, so the
number of steps is the request's) while recording what they publish to a bag in process
(``record.path``). The two bags carry byte-identical messages with identical log times on
every sampled topic; and each message equals, byte for byte, the message of the same stamp in
the headless ``abb-sim run`` bag of the same scenario (``run_scenario``), as
test/nodes/simulator/test_live_vs_headless.py compares the live and headless runs. The
diagnostics are not
compared (they report wall-clock rates).
"""


import pytest
from test_live_vs_headless import IMU_FIELDS, SEED, stamp_of
from test_simulator_node import Plant

from abb_ros.app.headless import STATE_TOPIC_TYPES, run_scenario
from abb_ros.io.bag.reader import iter_raw
from abb_ros.io.bag.writer import BagWriter
from abb_ros.io.files.scenario import load_scenario
from abb_ros.model.sensors.imu import TYPICAL_IMU

srv = pytest.importorskip('simulation_interfaces.srv', reason='simulation_interfaces is not '
                          'built (needs cmake and a C/C++ compiler)')
from rclpy.action import ActionClient  # noqa: E402
from simulation_interfaces.action import SimulateSteps  # noqa: E402
from simulation_interfaces.msg import Result  # noqa: E402

pytestmark = [pytest.mark.ros, pytest.mark.slow]

DRIVE = (('step', 3), ('action', 400), ('step', 1), ('action', 250), ('step', 46))
"""The drive: StepSimulation(3), SimulateSteps(400), ... (700 steps = 0.7 s)."""
STEPS = sum(n for _, n in DRIVE)
PERIOD_NS = 1_000_000


def parameters(scenario, bag) -> dict:
    p = scenario.params
    values = {f'drive.{name}': value for name, value in p.as_dict().items()}
    values.update({'spindle.initial_speed': float(scenario.omega), 'real_time_factor': 0.0,
                   'integration_rate_hz': 10000, 'publish_rate_hz': 1000, 'seed': SEED,
                   'imu.rate_hz': int(TYPICAL_IMU.rate), 'imu.gravity': TYPICAL_IMU.gravity,
                   'imu.position': [float(v) for v in TYPICAL_IMU.position],
                   'start_paused': True, 'record.path': str(bag)})
    values.update({f'imu.{k}': float(getattr(TYPICAL_IMU, k)) for k in IMU_FIELDS})
    return values


def drive_and_record(scenario, bag) -> dict[str, list[tuple[int, bytes]]]:
    """Run the drive on a fresh node recording to ``bag``; return {topic: [(log time, bytes)]}."""
    plant = Plant(**parameters(scenario, bag))
    try:
        action = ActionClient(plant.node, SimulateSteps, '/abb_simulator/simulate_steps')
        plant.wait(action.server_is_ready, 'the SimulateSteps server')
        for kind, steps in DRIVE:
            if kind == 'step':
                reply = plant.call(srv.StepSimulation, '/abb_simulator/step_simulation',
                                   srv.StepSimulation.Request(steps=steps))
                assert reply.result.result == Result.RESULT_OK
            else:
                goal = action.send_goal_async(SimulateSteps.Goal(steps=steps))
                plant.wait(goal.done, 'goal acceptance')
                result = goal.result().get_result_async()
                plant.wait(result.done, 'the goal result', timeout=60)
                assert result.result().result.result.result == Result.RESULT_OK
    finally:
        plant.close()   # finishes the bag
    got = {}
    for topic, _, data, log_time in iter_raw(bag):
        got.setdefault(topic.lstrip('/') if topic != '/clock' else topic, []).append(
            (log_time, data))
    return got


def test_the_same_steps_give_identical_bags_equal_to_the_headless_run(tmp_path):
    scenario = load_scenario('p3')
    first = drive_and_record(scenario, tmp_path / 'first')
    second = drive_and_record(scenario, tmp_path / 'second')
    sampled = [t for t in STATE_TOPIC_TYPES if t != 'spindle/speed']
    for topic in sampled:
        assert first.get(topic), f'{topic}: nothing recorded'
        assert first[topic] == second[topic], f'{topic}: the two runs differ'
    stamps = [stamp_of(data) for _, data in first['joint_states']]
    assert stamps[-1] == STEPS * PERIOD_NS

    scenario.duration = (STEPS + 1) * PERIOD_NS * 1e-9
    with BagWriter(tmp_path / 'headless') as bag:
        run_scenario(scenario, imu_config=TYPICAL_IMU, seed=SEED, bag=bag)
    headless = {}
    for topic, _, data, _ in iter_raw(tmp_path / 'headless'):
        topic = topic.lstrip('/') if topic != '/clock' else topic
        headless.setdefault(topic, {})[stamp_of(data)] = data
    for topic in sampled:
        live = [data for _, data in first[topic]]
        differing = [stamp_of(d) for d in live if headless[topic].get(stamp_of(d)) != d]
        assert not differing, f'{topic}: {len(differing)} messages differ from the headless run'
