"""Speed of stepping through simulation_interfaces (prints figures; asserts nothing).

The simulator node (Table 1 drive, defaults: 10 kHz integration, 1 kHz publishing, so a step
is 1 ms of simulated time and 10 RK4 steps) runs as a separate process, paused, at
real_time_factor 0; a client in this process measures over DDS:

  SimulateSteps: steps per wall second of one goal of --steps steps (send to result), against
  the same publish periods integrated and sampled in process without ROS (PlantSampler, the
  node's own loop without publishing): the ratio is what the action and DDS cost;
  StepSimulation(1): reply latency, p50 and p90 of --calls calls, against the std_srvs ~/step
  of the same node (the same one period behind a Trigger).

The issue asks for at least 1,000 steps/s and a p50 under 10 ms on this machine.

    .venv/bin/python benchmarks/bench_simulation_interfaces.py [--steps 5000] [--calls 200]
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

import numpy as np  # noqa: E402
import rclpy  # noqa: E402
from rclpy.action import ActionClient  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from simulation_interfaces.action import SimulateSteps  # noqa: E402
from simulation_interfaces.srv import StepSimulation  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

from abb_ros.model.dynamics.integrate import Simulation  # noqa: E402
from abb_ros.model.parameters.params import DriveParams  # noqa: E402
from abb_ros.model.sensors.imu import TYPICAL_IMU, ImuModel  # noqa: E402
from abb_ros.model.sensors.sampling import PlantSampler  # noqa: E402

NS = '/bench_simif'


def load() -> str:
    return 'load average %.2f %.2f %.2f' % os.getloadavg()


def in_process(periods: int) -> float:
    """Publish periods per wall second integrated and sampled without ROS."""
    sim = Simulation(DriveParams(), 811.2, 1e-4)
    sampler = PlantSampler(sim, ImuModel(TYPICAL_IMU, seed=0), 10, 10)
    sampler.next_period()
    start = time.perf_counter()
    for _ in range(periods):
        sampler.next_period()
    return periods / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--steps', type=int, default=5000)
    parser.add_argument('--calls', type=int, default=200)
    args = parser.parse_args()
    proc = subprocess.Popen(
        [sys.executable, '-m', 'abb_ros.nodes.simulator', '--ros-args', '-r', f'__ns:={NS}',
         '-p', 'real_time_factor:=0.0', '-p', 'start_paused:=true'],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    rclpy.init()
    node = rclpy.create_node('bench_simif')
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        def call(client, request):
            future = client.call_async(request)
            executor.spin_until_future_complete(future)
            return future.result()

        step = node.create_client(StepSimulation, f'{NS}/abb_simulator/step_simulation')
        trigger = node.create_client(Trigger, f'{NS}/abb_simulator/step')
        action = ActionClient(node, SimulateSteps, f'{NS}/abb_simulator/simulate_steps')
        for client in (step, trigger):
            while not client.service_is_ready():
                executor.spin_once(timeout_sec=0.1)
        while not action.server_is_ready():
            executor.spin_once(timeout_sec=0.1)
        call(step, StepSimulation.Request(steps=10))   # warm: first publications

        baseline = in_process(args.steps)
        start = time.perf_counter()
        goal = action.send_goal_async(SimulateSteps.Goal(steps=args.steps))
        executor.spin_until_future_complete(goal)
        result = goal.result().get_result_async()
        executor.spin_until_future_complete(result)
        rate = args.steps / (time.perf_counter() - start)
        print(f'SimulateSteps({args.steps}): {rate:.0f} steps/s; in process without ROS '
              f'{baseline:.0f} periods/s; ratio {rate / baseline:.2f}; {load()}')

        for name, client, request in (('StepSimulation(1)', step, StepSimulation.Request()),
                                      ('~/step (std_srvs)', trigger, Trigger.Request())):
            times = []
            for _ in range(args.calls):
                t0 = time.perf_counter()
                call(client, request)
                times.append(time.perf_counter() - t0)
            p50, p90 = np.percentile(times, [50, 90]) * 1e3
            print(f'{name}: p50 {p50:.2f} ms, p90 {p90:.2f} ms over {args.calls} calls; '
                  f'{load()}')
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown()


if __name__ == '__main__':
    main()
