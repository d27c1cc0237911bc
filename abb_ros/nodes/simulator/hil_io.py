"""The simulator node's HIL I/O: FG speed sensor, sensor faults, disturbances, markers.

Wiring only (the logic is in :mod:`abb_ros.model.sensors.speed_sensor`,
:mod:`abb_ros.model.sensors.faults`, :mod:`abb_ros.model.sensors.disturbances` and
:mod:`abb_ros.io.wire.markers`). :class:`HilIO` attaches to a
:class:`abb_ros.nodes.simulator.node.SimulatorNode`: it puts the FG and the fault filters into
the node's PlantSampler, serves ``~/apply_shock`` and ``~/swap_disc``, publishes
``visualization/markers`` and the ``faults and disturbances`` status on ``/diagnostics``
through the node's one path of published messages (``send``: the middleware, the live view,
the bag, the counters).
Semantics: docs/ros_api.md, 'Bench: measured speed, faults, disturbances, markers'.
"""

from __future__ import annotations

import math

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger

from abb_ros.io.wire import cdr, markers
from abb_ros.io.wire.topics import DIAGNOSTICS, MARKERS
from abb_ros.model.sensors import disturbances
from abb_ros.model.sensors.faults import ImuFaults, SpeedFaults
from abb_ros.model.sensors.speed_sensor import SpeedSensor
from abb_ros.nodes.simulator.hil_settings import HilSettings
from abb_ros.runtime.rate_slots import RateSlots

__all__ = ['HilIO']


class HilIO:
    """The HIL sensors, faults, disturbances and markers of a simulator node.

    See the module docstring. ``node`` must have ``sim``, ``sampler``, ``settings``,
    ``drive``, ``stamp_ns()``, ``pacer`` and ``send(topic, data, stamp_ns)``.
    """

    def __init__(self, node):
        self.node = node
        s = node.settings
        self.speed = SpeedSensor(s.hil.speed_sensor, s.seed)
        self.imu_faults = ImuFaults()
        self.speed_faults = SpeedFaults(seed=s.seed)
        sampler = node.sampler
        sampler.speed, sampler.imu_faults = self.speed, self.imu_faults
        sampler.speed_faults = self.speed_faults
        self.counters = dict(shocks=0, disc_swaps=0)
        self._last_event = ''
        self._marker_slots = RateSlots()
        node.create_service(Trigger, '~/apply_shock', self._on_shock)
        node.create_service(Trigger, '~/swap_disc', self._on_swap)
        self._active = {}
        self.apply(s.hil)

    # ---- parameters ----------------------------------------------------------------------
    def apply(self, b: HilSettings) -> None:
        """Apply new HIL I/O parameters (at a step boundary).

        A change of the active faults is reported on /diagnostics at once.
        """
        self.config = b
        self.speed.reconfigure(b.speed_sensor)
        f = self.imu_faults
        f.dropout, f.stuck = b.imu_dropout, b.imu_stuck
        f.accel_bias_step, f.gyro_bias_step = b.imu_accel_bias_step, b.imu_gyro_bias_step
        self.speed_faults.dropout, self.speed_faults.noise = b.speed_dropout, b.speed_noise
        active = self.active_faults()
        if active != self._active:
            self._active = active
            self.publish_diagnostics()

    def reset(self, seed: int) -> None:
        """Handle ~/reset: re-seed the FG and speed noise, forget the stuck IMU value."""
        self.speed.seed = self.speed_faults.seed = seed
        self.speed.reset()
        self.speed_faults.reset()
        self.imu_faults.reset()

    def active_faults(self) -> dict[str, object]:
        """Return {fault name: setting} of the IMU and FG faults now active."""
        return {**self.imu_faults.active(), **self.speed_faults.active()}

    # ---- disturbances --------------------------------------------------------------------
    def _on_shock(self, _request, response):
        self.node._apply_parameters()   # the parameters just set, not those of the last tick
        sim = self.node.sim
        step = self.config.shock_velocity
        try:
            y = disturbances.apply_shock(sim.y, sim.params.n_balls, step)
        except np.linalg.LinAlgError as err:   # singular L (cos(alpha) = 0): change nothing
            response.success, response.message = False, f'shock not applied: {err}'
            return response
        sim.y[:] = y
        self.counters['shocks'] += 1
        self._last_event = f'shock {list(step)} at t = {self.node.stamp_ns() * 1e-9:.6f} s'
        self.publish_diagnostics()
        response.success, response.message = True, self._last_event
        return response

    def _on_swap(self, _request, response):
        self.node._apply_parameters()
        node, sim, b = self.node, self.node.sim, self.config
        result = node.set_parameters([Parameter('drive.eps', value=b.disc_eps)])[0]
        if not result.successful:
            response.success = False
            response.message = f'disc not swapped: {result.reason}'
            return response
        node._apply_parameters()
        delta = math.radians(b.disc_angle_deg)
        sim.y[:] = disturbances.swap_disc(sim.y, sim.params.n_balls, delta)
        self.speed.shift_angle(delta)
        self.counters['disc_swaps'] += 1
        self._last_event = (f'disc swap to eps = {b.disc_eps:g} m, imbalance moved by '
                            f'{b.disc_angle_deg:g} deg at t = {node.stamp_ns() * 1e-9:.6f} s')
        self.publish_diagnostics()
        response.success, response.message = True, self._last_event
        return response

    # ---- outputs -------------------------------------------------------------------------
    def on_sample(self, sample, stamp_ns: int) -> None:
        """Publish the markers if this sample, stamped ``stamp_ns``, opens a visualisation slot.

        The slots are 1 / visualization.rate_hz long, in simulated time.
        """
        if sample.y is None:
            return
        if not self._marker_slots.opens(stamp_ns, self.config.visualization_rate_hz):
            return
        self.node.send(MARKERS, markers.marker_array(
            stamp_ns, sample.y, self.node.sim.params, self.config.visualization_exaggeration),
            stamp_ns)

    def publish_diagnostics(self) -> None:
        """Publish the 'faults and disturbances' status: WARN with the active faults, else OK."""
        active = self.active_faults()
        level = DiagnosticStatus.WARN if active else DiagnosticStatus.OK
        message = ('active faults: ' + ', '.join(active)) if active else 'no fault injected'
        values = dict(active, **self.counters, last_disturbance=self._last_event,
                      speed_sensor_edges=self.speed.edges)
        stamp_ns = self.node.stamp_ns()
        self.node.send(DIAGNOSTICS, cdr.diagnostics(
            stamp_ns,
            f'{self.node.get_fully_qualified_name()}: faults and disturbances', level,
            message, values), stamp_ns)
