"""Speed of the lockstep harness (prints figures; asserts nothing).

P3's drive (metal washers) from rest under spin_controller, everything in this process over
DDS (one rclpy Context, the harness' executor):
  lockstep: publish periods per wall second advanced by LockstepPlant.advance with the
  controller answering every period (and, for reference, with no controller: answers = 0);
  real time: the same nodes free-running at real_time_factor 1 (the simulator's own pacing),
  periods per wall second and the fraction of periods the controller answered.

    .venv/bin/python benchmarks/bench_lockstep.py [--periods 1000] [--rates 1000 200]
"""

import argparse
import os
import random
import time

os.environ.setdefault('ROS_DOMAIN_ID', str(random.randint(1, 101)))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

from rclpy.parameter import Parameter  # noqa: E402

from abb_ros.io.scenario import load_scenario  # noqa: E402
from abb_ros.nodes.spin_controller import SpinController  # noqa: E402
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
    """(periods per wall second, fraction answered) with the plant free-running in real time
    (real_time_factor 1, unpaused through ~/pause over DDS)."""
    from std_srvs.srv import SetBool
    with LockstepPlant({**FROM_REST, 'publish_rate_hz': rate, 'imu.rate_hz': rate}) as plant:
        controller_for(plant)
        plant.advance(1)  # connected, as above
        plant.sim.set_parameters([Parameter('real_time_factor', value=1.0)])
        client = plant.node.create_client(
            SetBool, f'{plant.sim.get_fully_qualified_name()}/pause')
        plant.spin_until(client.service_is_ready, 'the ~/pause service')
        n0, c0 = len(plant.trace()), plant.sim.counters['commands_accepted']
        future = client.call_async(SetBool.Request(data=False))
        start = time.perf_counter()
        while time.perf_counter() - start < seconds:
            plant.executor.spin_once(timeout_sec=0.01)
        wall = time.perf_counter() - start
        assert future.done() and future.result().success
        periods = len(plant.trace()) - n0
        answered = plant.sim.counters['commands_accepted'] - c0
        return periods / wall, answered / max(periods, 1)


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
        print(f'publish rate {rate} Hz: lockstep {with_c:.0f} periods/s with spin_controller '
              f'({with_c / rate:.2f} x real time), {without:.0f} periods/s without a '
              f'controller; real time: {rt:.0f} periods/s, {answered:.1%} of them answered')


if __name__ == '__main__':
    main()
