"""Headless runs: a scenario integrated as fast as possible, without DDS, optionally to a bag.

The plant is stepped by the same :class:`~abb_ros.model.sensors.sampling.PlantSampler` as the live
simulator node and its messages hold the same contents (:mod:`abb_ros.io.wire.ros_messages`),
encoded straight to CDR by :mod:`abb_ros.io.wire.cdr` (byte-identical to the serialised rclpy
messages, without building them), so a headless bag and a live bag of the same scenario hold
the same messages (test/nodes/simulator/test_live_vs_headless.py).
Speed commands of the scenario take effect at the first publish instant at or after their
time, as a command arriving on ``spindle/speed_cmd`` does in the node.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from abb_ros.io.files.scenario import Scenario
from abb_ros.io.wire import topics
from abb_ros.model.dynamics.initial import initial_state
from abb_ros.model.dynamics.integrate import (
    DEFAULT_DT,
    MAX_RUN_STEPS,
    Simulation,
    fixed_step_reason,
)
from abb_ros.model.sensors.imu import TYPICAL_IMU, ImuConfig, ImuModel
from abb_ros.model.sensors.sampling import PlantSampler
from abb_ros.model.sensors.speed_sensor import SpeedSensor, SpeedSensorConfig

__all__ = ['RunResult', 'run_scenario', 'check_duration', 'STATE_TOPIC_TYPES']

PUBLISH_DT = 1e-3
"""Publish period of the state topics [s] (the node's default 1 kHz)."""

CHUNK_PERIODS = 1000
"""Most publish periods integrated in one call of the compiled loop (1 s at 1 kHz)."""
CHUNK_WALL_S = 0.2
"""Wall time a chunk may take: a stiff drive's chunks shrink to it (a signal is acted on
between two calls of the compiled loop, so SIGINT stops a run within about this long).
Chunking changes no sample: both integrators give the same states for any chunk sizes."""
STATE_TOPIC_TYPES = {t.name: t.type for t in topics.sampled_topics()}
"""Topics of a headless bag -> type name: those a simulation sample produces."""


@dataclass
class RunResult:
    """Samples of the state at every publish instant, and timing."""

    scenario: Scenario
    t: np.ndarray          # [s]
    y: np.ndarray          # states, shape (len(t), 2N)
    wall_time: float       # [s], integration and writing (the one-time compile excluded)
    messages: int          # written to the bag (0 without one)
    compile_time: float = 0.0   # [s], numba's one-time compilation of the kernels
    refined_steps: int = 0      # steps split into contact sub-steps
    max_substeps: int = 1       # most sub-steps in one step
    rolling_switches: int = 0   # rolling regime switches located inside steps
    contact_step_note: str = ''  # integrate.contact_step_note of the run
    integrator: str = 'rk4'     # the integrator that ran (integrate.INTEGRATORS)
    integrator_note: str = ''   # why adaptive fell back to the fixed step, or ''

    @property
    def real_time_factor(self) -> float:
        """Simulated time over wall time (inf when the wall time is 0)."""
        span = float(self.t[-1] - self.t[0])
        return span / self.wall_time if self.wall_time > 0 else float('inf')


def check_duration(duration: float, publish_dt: float = PUBLISH_DT, dt: float | None = None
                   ) -> None:
    """Refuse a run shorter than one publish period or longer than MAX_RUN_STEPS steps of dt.

    A run shorter than a publish period would publish nothing; ``dt`` None is DEFAULT_DT.
    """
    from abb_ros.model.parameters.params import ParamError
    dt = DEFAULT_DT if dt is None else dt
    longest = MAX_RUN_STEPS * dt
    if not duration >= publish_dt * (1 - 1e-9):
        raise ParamError('duration', duration, f'[{publish_dt:g}, {longest:g}] s',
                         'shorter than one publish period')
    if not duration <= longest:
        raise ParamError('duration', duration, f'[{publish_dt:g}, {longest:g}] s',
                         f'at most {MAX_RUN_STEPS} steps of dt = {dt:g} s')


def _steps_per(period: float, dt: float, what: str) -> int:
    k = int(round(period / dt))
    if k < 1 or abs(k * dt - period) > 1e-9 * period:
        from abb_ros.model.parameters.params import ParamError
        raise ParamError(what, period, f'a whole multiple of the step dt = {dt:g} s')
    return k


def run_scenario(
        scenario: Scenario, dt: float = DEFAULT_DT, publish_dt: float = PUBLISH_DT,
        imu_config: ImuConfig | None = None, seed: int = 0, bag=None,
        progress=None, speed_config: SpeedSensorConfig | None = None,
        integrator: str = 'rk4') -> RunResult:
    """Integrate ``scenario`` for its duration.

    ``integrator``: ``rk4`` (the fixed step of dt, as the live node) or ``adaptive``
    (:data:`abb_ros.model.dynamics.integrate.INTEGRATORS`: the states at the same publish
    stamps from its dense output, the IMU and FG read from those states).

    The FG speed sensor (``spindle/speed``) has ``speed_config`` (default the node's) and the
    same ``seed`` as the IMU, so a node with the same settings publishes the same readings.

    bag : abb_ros.io.bag.writer.BagWriter, optional
        Receives every message (with ``/clock``, as the node does on simulated time).
    progress : callable(float), optional
        Called with the simulated seconds done after each chunk (for a progress bar).
    """
    imu_config = imu_config or TYPICAL_IMU
    check_duration(scenario.duration, publish_dt, dt)
    sim = _simulation(scenario, dt, integrator)
    publish_every = _steps_per(publish_dt, dt, 'publish_dt')
    imu_every = _steps_per(1.0 / imu_config.rate, dt, 'imu rate')
    sampler = PlantSampler(sim, ImuModel(imu_config, seed), publish_every, imu_every,
                           speed=SpeedSensor(speed_config, seed))
    if bag is not None:
        for topic, type_name in STATE_TOPIC_TYPES.items():
            bag.add_topic(topic, type_name)
    run = _Collector(sim, sampler, publish_every, bag, imu_config)
    compile_time = _compile(sim, publish_every)
    start = time.perf_counter()
    run.write_initial()
    commands = list(scenario.commands)
    total = int(round(scenario.duration / dt)) // publish_every
    done, most = 0, 1   # the first period measures the drive
    while done < total:
        chunk = min(most, _next_chunk(sim, commands, total - done, publish_every * dt))
        began = time.perf_counter()
        run.advance(chunk)
        most = _periods_within(CHUNK_WALL_S, (time.perf_counter() - began) / chunk)
        done += chunk
        if progress is not None:
            progress(chunk * publish_every * dt)
    states = np.concatenate([np.atleast_2d(s) for s in run.states])
    wall = time.perf_counter() - start
    return RunResult(scenario, np.array(run.times), states, wall, run.written, compile_time,
                     sim.refined_steps, sim.max_substeps, sim.rolling_switches,
                     sim.contact_step_note, sim.integrator_used, _note(sim))


def _simulation(scenario: Scenario, dt: float, integrator: str) -> Simulation:
    """Return the simulation of ``scenario`` from its initial state."""
    p = scenario.params
    y0 = initial_state(p, scenario.omega, phi0=scenario.phi0, deck0=scenario.deck0)
    return Simulation(p, scenario.omega, dt, spindle=scenario.spindle, y0=y0,
                      integrator=integrator)


def _compile(sim: Simulation, publish_every: int) -> float:
    """Compile the kernels (numba) outside the timed part; return the seconds it took."""
    t_compile = time.perf_counter()
    sim.advance(0)
    sim.trajectory(0, publish_every)
    return time.perf_counter() - t_compile


def _periods_within(wall_s: float, period_wall_s: float) -> int:
    """Return the publish periods that take about ``wall_s`` (1 to CHUNK_PERIODS)."""
    if period_wall_s * CHUNK_PERIODS <= wall_s:
        return CHUNK_PERIODS
    return max(1, int(wall_s / period_wall_s))


def _next_chunk(sim: Simulation, commands: list, remaining: int, period: float) -> int:
    """Apply the commands due now; return the periods until the next command or report."""
    while commands and commands[0].t <= sim.t + 1e-12:
        sim.set_command(commands.pop(0).value)
    chunk = min(remaining, CHUNK_PERIODS)
    if commands:
        until = int(np.ceil((commands[0].t - sim.t) / period - 1e-9))
        chunk = max(1, min(chunk, until))
    return chunk


class _Collector:
    """The states at every publish instant of a run, and its messages written to the bag.

    One of three paths per chunk: without a bag the compiled loop samples the state alone;
    with one, many periods in one compiled call encoded at once where the sampler batches,
    else period by period.
    """

    def __init__(self, sim: Simulation, sampler: PlantSampler, publish_every: int, bag,
                 imu_config: ImuConfig):
        self.sim, self.sampler, self.publish_every = sim, sampler, publish_every
        self.bag, self.imu_config = bag, imu_config
        self.dt_ns = int(round(sim.dt * 1e9))
        self.times = [sim.t]
        self.states = [sim.y.copy()]
        self.written = 0

    def write_initial(self) -> None:
        """Write the initial state, at step 0, to the bag (if any)."""
        if self.bag is not None:
            self._write(s for s in [self.sampler.sample_now()] if s is not None)

    def advance(self, chunk: int) -> None:
        """Run ``chunk`` publish periods on, collecting their states and messages."""
        if self.bag is None:
            self._states_only(chunk)
        elif self.sampler.batches():
            self._batched(chunk)
        else:
            for _ in range(chunk):
                self._write(self.sampler.next_period())
                self.times.append(self.sim.t)
                self.states.append(self.sim.y[None, :].copy())

    def _states_only(self, chunk: int) -> None:
        sim, every = self.sim, self.publish_every
        self.states.append(sim.trajectory(chunk * every, every))
        self.times.extend(sim.t0 + (sim.steps - every * np.arange(chunk - 1, -1, -1)) * sim.dt)

    def _batched(self, chunk: int) -> None:
        from abb_ros.io.wire import cdr
        batch = self.sampler.next_periods(chunk)
        for stamp_ns, encoded in cdr.batch_cdr(batch, self.dt_ns, self.imu_config,
                                               with_clock=True):
            self.bag.write_many(encoded, stamp_ns)
            self.written += len(encoded)
        if batch.error is not None:
            raise batch.error
        self.times.extend(self.sim.t0 + np.array(batch.steps) * self.sim.dt)
        self.states.append(batch.y)

    def _write(self, samples) -> None:
        from abb_ros.io.wire import cdr
        for sample in samples:
            stamp_ns, encoded = cdr.sample_cdr(sample, self.dt_ns, self.imu_config,
                                               with_clock=True)
            self.bag.write_many(encoded, stamp_ns)
            self.written += len(encoded)


def _note(sim) -> str:
    """Return why an adaptive run took the fixed step, or ''."""
    if sim.integrator == sim.integrator_used:
        return ''
    return f'adaptive integrator fell back to the fixed RK4 step: {fixed_step_reason(sim.params)}'

