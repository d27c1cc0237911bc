"""Speed of the lockstep harness (prints figures; asserts nothing).

P3's drive (metal washers) from rest under spin_controller, over DDS:
  lockstep: publish periods per wall second advanced by LockstepPlant.advance with the
  controller answering every period (and, for reference, with no controller: answers = 0);
  real time: the simulator (real_time_factor 1) and spin_controller as separate processes, as
  bench.launch.py runs them: periods per wall second and commands per period, seen by a probe.

    .venv/bin/python benchmarks/bench_lockstep.py [--periods 1000] [--rates 1000 200]
"""

import argparse
import os
import random
import signal
import subprocess
import sys
import time

os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

from rclpy.parameter import Parameter  # noqa: E402

from abb_ros.io.files.scenario import load_scenario  # noqa: E402
from abb_ros.nodes.simulator.node import make_executor  # noqa: E402
from abb_ros.nodes.spin_controller.node import SpinController  # noqa: E402
from abb_ros.testing.lockstep import LockstepPlant, drive_parameters  # noqa: E402

P3 = load_scenario('p3')
FROM_REST = {**drive_parameters(P3.params), 'spindle.initial_speed': 0.0}


def controller_for(plant: LockstepPlant) -> SpinController:
    node = SpinController(context=plant.context, parameter_overrides=[
        Parameter(k, value=v) for k, v in drive_parameters(P3.params).items()])
    plant.add_node(node)
    return node


def lockstep(rate: int, periods: int, with_controller: bool) -> float:
    """Periods per wall second of plant.advance (after a first period, which connects)."""
    with LockstepPlant({**FROM_REST, 'publish_rate_hz': rate, 'imu.rate_hz': rate}) as plant:
        if with_controller:
            controller_for(plant)
        plant.advance(1)
        start = time.perf_counter()
        plant.advance(periods)
        return periods / (time.perf_counter() - start)


def real_time(rate: int, seconds: float) -> tuple[float, float]:
    """(joint_states per wall second, commands per joint_states) seen by a probe in this
    process, with the simulator (real_time_factor 1) and spin_controller as separate processes,
    as bench.launch.py runs them."""
    import rclpy
    from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64

    ns = f'/bench_rt_{os.getpid()}'
    params = [f'drive.{k[len("drive."):]}:={v!r}' for k, v in FROM_REST.items()
              if k.startswith('drive.')]
    params += [f'publish_rate_hz:={rate}', f'imu.rate_hz:={rate}']
    procs = [subprocess.Popen([sys.executable, '-m', f'abb_ros.nodes.{module}', '--ros-args',
                               '-r', f'__ns:={ns}', *[a for p in params for a in ('-p', p)]],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
             for module in ('simulator', 'spin_controller')]
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node('bench_rt_probe', context=ctx)
    qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
    states, commands = [], []
    node.create_subscription(JointState, f'{ns}/joint_states', states.append, qos, raw=True)
    node.create_subscription(Float64, f'{ns}/spindle/speed_cmd', commands.append, qos,
                             raw=True)
    executor = make_executor(ctx)
    executor.add_node(node)
    try:
        deadline = time.monotonic() + 300  # start-up: numba caches, the band table
        while not commands and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        end = time.monotonic() + 1.0  # let the start settle
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.01)
        n0, c0, start = len(states), len(commands), time.perf_counter()
        while time.perf_counter() - start < seconds:
            executor.spin_once(timeout_sec=0.01)
        wall = time.perf_counter() - start
        periods = len(states) - n0
        return periods / wall, (len(commands) - c0) / max(periods, 1)
    finally:
        for proc in procs:
            proc.send_signal(signal.SIGINT)
        for proc in procs:
            proc.wait(timeout=60)
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--periods', type=int, default=1000)
    parser.add_argument('--seconds', type=float, default=5.0)
    parser.add_argument('--rates', type=int, nargs='+', default=[1000, 200])
    args = parser.parse_args()
    for rate in args.rates:
        with_c = lockstep(rate, args.periods, True)
        without = lockstep(rate, args.periods, False)
        rt, answered = real_time(rate, args.seconds)
        print(f'publish rate {rate} Hz: lockstep (one process) {with_c:.0f} periods/s with '
              f'spin_controller ({with_c / rate:.2f} x real time), {without:.0f} periods/s '
              f'without a controller; real time (separate processes) {rt:.0f} periods/s, '
              f'{answered:.3f} commands per period')


if __name__ == '__main__':
    main()
