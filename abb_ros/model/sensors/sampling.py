"""When the plant is sampled: the schedule shared by the live node and the headless run.

A :class:`PlantSampler` advances a :class:`~abb_ros.model.dynamics.integrate.Simulation` to the
next instant at which the state (every ``publish_every`` steps) or the IMU (every ``imu_every``
steps) is due, and returns :class:`Sample` s there. Instants are multiples of the step
count, which never goes back (``Simulation.reset`` keeps it), so stamps computed from it in
integer nanoseconds (``steps * dt_ns``) never drift. The live node and ``abb-sim run`` both
drive this class, so the same seed, parameters and commands give the same samples.
:meth:`PlantSampler.next_periods` takes many periods at once, as a :class:`SampleBatch`
(one compiled call integrates them, another reads the IMU at all of them), when every state
instant is an IMU instant and no reading is faulted: the same samples, at a fraction of the
per-period cost.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from abb_ros.model.dynamics.integrate import StateError
from abb_ros.model.dynamics.state import PHI
from abb_ros.model.sensors.faults import ImuFaults, SpeedFaults
from abb_ros.model.sensors.imu import ImuModel, ImuReading
from abb_ros.model.sensors.speed_sensor import SpeedSensor

__all__ = ['Sample', 'Outputs', 'SampleBatch', 'PlantSampler']


@dataclass(frozen=True)
class Sample:
    """The plant's readings at step ``steps``.

    ``y`` (state copy, shape (2N,)) when the state is due, ``imu`` when the IMU is due (else
    None); ``n`` the ball count of ``y``; ``effort`` the spindle motor's torque [N m] in
    torque mode (None in speed modes); ``speed`` the FG reading [rad/s] with the state (None
    without a speed sensor or during its dropout).
    """

    steps: int
    n: int
    y: np.ndarray | None
    imu: ImuReading | None
    effort: float | None = None
    speed: float | None = None
    outputs: np.ndarray | None = None
    """With the state and the IMU from one compiled call: every output in one vector
    (:class:`Outputs`), ``y`` and ``imu`` views of it; else None."""

    def stamp_ns(self, dt_ns: int, epoch_ns: int = 0) -> int:
        """Return the exact time stamp [ns] of this sample: epoch + steps * dt."""
        return epoch_ns + self.steps * dt_ns

    def is_finite(self) -> bool:
        """Return whether the state, the IMU and speed readings and the effort are finite.

        A sum is NaN or infinite when a term is; finite terms overflow it only beyond 1e300,
        far outside the state envelope that the integrator enforces. Python floats: numpy's
        reductions cost more on arrays this small.
        """
        if self.outputs is not None:   # y, the IMU reading, the deck's pose and the effort
            total = sum(self.outputs.tolist())
            return math.isfinite(total if self.speed is None else total + self.speed)
        total = 0.0 if self.y is None else sum(self.y.tolist())
        if self.imu is not None:
            total += sum(self.imu.accel.tolist()) + sum(self.imu.gyro.tolist())
        for value in (self.speed, self.effort):
            if value is not None:
                total += value
        return math.isfinite(total)


class Outputs:
    """Where each output of one period lies in :attr:`Sample.outputs`, for ``n`` balls.

    ``[0, 2N)`` the state y; ``imu``: specific force (3) [m/s^2] then angular rate (3)
    [rad/s]; ``deck``: the deck's pose (7) and twist (6) (:func:`~abb_ros.model.sensors.imu.
    deck_pose_twist`); ``effort``: the motor torque [N m] (0 in speed modes); ``zero``: 0.0
    (the balls' efforts).
    """

    @staticmethod
    @functools.lru_cache(maxsize=None)
    def of(n: int) -> 'Outputs':
        """Return the (shared) layout for ``n`` balls."""
        return Outputs(n)

    def __init__(self, n: int):
        self.n = n
        self.state = 2 * (PHI + n)
        self.imu = self.state
        self.deck = self.imu + 6
        self.effort = self.deck + 13
        self.zero = self.effort + 1
        self.size = self.zero + 1


@dataclass(frozen=True)
class SampleBatch:
    """The samples of consecutive publish periods, each with the state and the IMU.

    Row j is the :class:`Sample` at step ``steps[j]``: state ``y[j]``, IMU reading
    ``imu[j]`` (accel, gyro), FG reading ``speed[j]`` (``speed`` None without a speed
    sensor), no effort (speed modes). ``error``: the :class:`StateError` that ended the
    batch early (the rows are the periods completed before it), else None.
    """

    steps: list[int]
    n: int
    y: np.ndarray
    imu: np.ndarray
    speed: list[float] | None
    error: StateError | None = None

    def samples(self) -> list[Sample]:
        """Return the rows as :class:`Sample` s."""
        speed = self.speed or [None] * len(self.steps)
        return [Sample(steps, self.n, y, ImuReading(imu[:3], imu[3:]), None, v)
                for steps, y, imu, v in zip(self.steps, self.y, self.imu, speed)]


class PlantSampler:
    """Advance ``sim`` publish period by publish period, sampling state and IMU.

    publish_every, imu_every : int
        Steps between state samples and between IMU samples (>= 1).
    speed : SpeedSensor, optional
        The FG, read with every state sample.
    imu_faults, speed_faults : optional
        :mod:`abb_ros.model.sensors.faults` applied to the readings.

    A period whose one sample has the state and the IMU (imu_every = publish_every) is
    integrated and read in two compiled calls (:meth:`_fused_period`); other periods step
    from sample instant to sample instant. The same samples either way.
    """

    def __init__(self, sim, imu: ImuModel, publish_every: int, imu_every: int,
                 speed: SpeedSensor | None = None, imu_faults: ImuFaults | None = None,
                 speed_faults: SpeedFaults | None = None):
        self.sim = sim
        self.imu = imu
        self.speed = speed
        self.imu_faults = imu_faults
        self.speed_faults = speed_faults
        self.set_rates(publish_every, imu_every)

    def set_rates(self, publish_every: int, imu_every: int) -> None:
        """Set the steps between state samples and between IMU samples (>= 1)."""
        if publish_every < 1 or imu_every < 1:
            raise ValueError('publish_every and imu_every must be >= 1 step')
        self.publish_every = int(publish_every)
        self.imu_every = int(imu_every)

    def sample_now(self) -> Sample | None:
        """Return what is due at the current step (None if nothing)."""
        steps = self.sim.steps
        state_due = steps % self.publish_every == 0
        imu_due = steps % self.imu_every == 0
        if not (state_due or imu_due):
            return None
        y = self.sim.y.copy() if state_due else None
        reading = speed = effort = None
        if imu_due:
            s = self.sim.layout
            qdd = self.sim.accelerations()
            reading = self._given(self.imu.read(self.sim.y[s.q], self.sim.y[s.qd], qdd))
        if state_due:
            speed, effort = self._speed_and_effort()
        return Sample(steps, self.sim.params.n_balls, y, reading, effort, speed)

    def _given(self, reading: ImuReading) -> ImuReading | None:
        """Return the IMU reading given out for the sensor's ``reading`` (the IMU faults)."""
        return reading if self.imu_faults is None else self.imu_faults.apply(reading)

    def _speed_and_effort(self) -> tuple[float | None, float | None]:
        """Return what comes with a state sample: (FG reading, motor torque).

        The FG reading after its faults (None without a speed sensor or in a dropout); the
        motor torque [N m] (None in speed modes).
        """
        sim, speed = self.sim, None
        if self.speed is not None:
            speed = self.speed.update(sim.t, sim.theta, sim.omega)
            if self.speed_faults is not None:
                speed = self.speed_faults.apply(speed)
        effort = sim.motor_torque
        return speed, None if math.isnan(effort) else effort

    def next_period(self) -> list[Sample]:
        """Advance to the next state instant (a multiple of publish_every).

        Return every sample due after the current step up to and including it, in time order.

        Raises :class:`abb_ros.model.dynamics.integrate.StateError` like ``Simulation.advance``
        (the samples of the failed period are lost; none is non-finite).
        """
        target = (self.sim.steps // self.publish_every + 1) * self.publish_every
        if self.imu_every == self.publish_every:
            return [self._fused_period(target)]
        out = []
        while self.sim.steps < target:
            next_imu = (self.sim.steps // self.imu_every + 1) * self.imu_every
            self.sim.advance(min(target, next_imu) - self.sim.steps)
            sample = self.sample_now()
            if sample is not None:
                out.append(sample)
        return out

    def _fused_period(self, target: int) -> Sample:
        """Advance to ``target``, a state and IMU instant, and sample there (two compiled calls).

        The state and q'' in one compiled call, the IMU reading and the deck's pose in
        another, into one :attr:`Sample.outputs` vector.
        """
        sim = self.sim
        n = sim.params.n_balls
        at = Outputs.of(n)
        out = np.empty(at.size)
        qdd = np.empty(at.state // 2)
        sim.advance_accelerations(target - sim.steps, qdd)
        self.imu.read_with_pose(sim.y, n, qdd, out)
        y, outputs = out[:at.state], out
        reading = ImuReading(out[at.imu:at.imu + 3], out[at.imu + 3:at.deck])
        given = self._given(reading)
        if given is not reading:   # a fault changed it: no longer the vector's
            reading, outputs = given, None
        speed, effort = self._speed_and_effort()
        out[at.effort] = 0.0 if effort is None else effort
        out[at.zero] = 0.0
        return Sample(target, n, y, reading, effort, speed, outputs)

    def batches(self) -> bool:
        """Return whether :meth:`next_periods` applies now.

        At a state instant, with every state instant an IMU instant, no faults and no
        effort (speed modes).
        """
        return (self.imu_every == self.publish_every and self.imu_faults is None
                and self.speed_faults is None and self.sim.steps % self.publish_every == 0
                and math.isnan(self.sim.motor_torque))

    def next_periods(self, count: int) -> SampleBatch:
        """Advance ``count`` publish periods; return their samples (needs :meth:`batches`).

        The samples of ``count`` calls of :meth:`next_period`; a :class:`StateError` ends
        the batch at the last good period and comes back in ``SampleBatch.error``.
        """
        sim, every = self.sim, self.publish_every
        step0 = sim.steps
        ys = np.empty((count, sim.y.size))
        error = None
        try:
            sim.trajectory(count * every, every, out=ys)
        except StateError as exc:
            error = exc
        rows = (sim.steps - step0) // every
        ys = ys[:rows]
        steps = list(range(step0 + every, step0 + (rows + 1) * every, every))
        n = sim.params.n_balls
        imu = self.imu.read_many(ys, sim.accelerations_along(ys, steps), n)
        speed = None
        if self.speed is not None:
            s, t0, dt, update = sim.layout, sim.t0, sim.dt, self.speed.update
            angles = ys[:, [s.theta_index, s.omega_index]].tolist()
            speed = [update(t0 + k * dt, theta, omega)
                     for k, (theta, omega) in zip(steps, angles)]
        return SampleBatch(steps, n, ys, imu, speed, error)
