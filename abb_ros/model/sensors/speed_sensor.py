"""The spindle drive's frequency generator (FG): a measured speed with a real sensor's errors.

A BLDC spindle motor gives ``pulses_per_rev`` FG pulses per revolution (from its Hall
sensors or an FG winding: 3 per pole pair on the commutation signals, so 6 for a 4-pole,
12 for an 8-pole motor; the default 6 is a 4-pole CD-ROM spindle). The drive's controller
captures each pulse edge with a timer of clock ``timer_hz`` and computes

    omega_FG = 2 pi / (pulses_per_rev * T),     T = (n_k - n_{k-1}) / timer_hz

from the tick counts n_k of two consecutive edges, so the reading is quantised (a period of
N ticks reads 2 pi timer_hz / (pulses_per_rev N), a relative step of 1 / N) and each edge
time carries the sensor's Gaussian jitter (standard deviation ``edge_jitter`` [s]) before it
is captured: n_k = floor((t_k + e_k) * timer_hz). The reading updates at each edge and holds
in between; with no edge for ``timeout`` seconds it reads 0 (a stopped spindle). Until two
edges have been seen it reads 0 as well. A single-channel FG cannot see the direction: the
reading is a magnitude.

Pitch error: the FG's magnet poles are not evenly spaced. Edge k (of every integer k, so of
every revolution) is at the rotor angle

    theta_k = k * pitch + delta_{k mod pulses_per_rev},     pitch = 2 pi / pulses_per_rev,

and the pattern delta_0..delta_{pulses_per_rev - 1} [rad] repeats every revolution. An
edge interval then reads omega * pitch / (pitch + delta_k - delta_{k-1}) at a steady omega:
a once-per-revolution pattern on the reading, the FG's dominant error on a real drive. The
pattern is drawn once from ``default_rng([seed, 3])`` (standard normals, mean removed, scaled
to an RMS of exactly ``pitch_error`` [rad]): its zero mean keeps the edges' mean position, and
the revolution time (the sum of the intervals) is exact. With ``pitch_error`` 0 (the default)
the edges are at k * pitch exactly and nothing is drawn; with one pulse per revolution a
zero-mean pattern is 0. ``pitch_error`` must stay below pi / pulses_per_rev^1.5 (then every
|delta_k| < pitch / 2 and the edges keep their order).

Low speed: at a steady omega the longest edge interval is (pitch + max_k(delta_k -
delta_{k-1})) / omega; below :attr:`SpeedSensor.min_speed` (that angle / ``timeout``; 2 pi /
(pulses_per_rev * timeout) without pitch error, 10.47 rad/s at the defaults) it exceeds the
timeout, and the reading drops to 0 between edges (it shows each interval's speed for
``timeout`` after the edge that ends it, then 0). :meth:`SpeedSensor.state` names this.

Edge times come from the state samples: between two samples the rotor angle is the cubic
Hermite interpolant of (theta, omega) at both ends, and each crossing of a multiple of
2 pi / pulses_per_rev is found by Newton's method on it (exact to O(h^4) in the sample
period h; at the default 1 kHz the edge-time error is far below a 1 MHz tick).

The jitter comes from a numpy Generator seeded with ``seed`` (independent of the IMU's):
the same seed and states give the same readings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from abb_ros.model.jit import KernelSet
from abb_ros.model.parameters.params import ParamError
from abb_ros.model.sensors.normals import NormalStream

__all__ = ['SpeedSensorConfig', 'SpeedSensor', 'fg_speed', 'pitch_pattern', 'max_pitch_error',
           'FG_STATES', 'SPEED_SEED_STREAM', 'PITCH_SEED_STREAM', 'STOPPED_FRACTION']

SPEED_SEED_STREAM = 1
"""Second seed word of the FG's generator: ``default_rng([seed, 1])``, so its jitter is
independent of the IMU noise drawn from ``default_rng(seed)``."""

PITCH_SEED_STREAM = 3
"""Second seed word of the pitch-error pattern's generator: ``default_rng([seed, 3])`` (2 is
the speed-noise fault's, :mod:`abb_ros.model.sensors.faults`)."""

STOPPED_FRACTION = 0.01
"""Below this fraction of :attr:`SpeedSensor.min_speed` the spindle counts as stopped."""

FG_STATES = ('measuring', 'waiting_for_edges', 'below_min_speed', 'stopped')
"""What :meth:`SpeedSensor.state` returns: the spindle at or above the FG's minimum speed
with a reading, or still without one (fewer than two edges since the start or a timeout);
turning below the minimum speed (the reading drops to 0 between edges); stopped (below
STOPPED_FRACTION of it)."""

_NEWTON_ITERATIONS = 4
# FG state vector of the kernel: tick count and time [s] of the last captured edge (valid when
# HAS_EDGE is 1), the held reading [rad/s], the edge count.
EDGE_TICKS, EDGE_T, VALUE, EDGES, HAS_EDGE, N_STATE = range(6)

kernel = KernelSet()


@dataclass(frozen=True)
class SpeedSensorConfig:
    """Settings of the frequency generator (FG) speed sensor.

    FG pulses per revolution, capture timer clock [Hz], edge jitter std [s], zero-speed
    timeout [s], RMS pitch error of the edges [rad] (below :func:`max_pitch_error`).
    """

    pulses_per_rev: int = 6
    timer_hz: float = 1.0e6
    edge_jitter: float = 1.0e-6
    timeout: float = 0.1
    pitch_error: float = 0.0

    def __post_init__(self):
        bound = max_pitch_error(self.pulses_per_rev)
        if not 0.0 <= self.pitch_error < bound:
            raise ParamError('speed_sensor.pitch_error', self.pitch_error,
                             f'[0, pi / pulses_per_rev^1.5) = [0, {bound:.6g}) rad')

    @property
    def pitch(self) -> float:
        """Rotor angle between two FG edges [rad]."""
        return 2.0 * math.pi / self.pulses_per_rev


def max_pitch_error(pulses_per_rev: int) -> float:
    """Return the bound [rad] of the RMS pitch error, pi / pulses_per_rev^1.5 (exclusive).

    A zero-mean pattern of that RMS has every |delta_k| < pitch / 2, so the edges keep their
    order.
    """
    return math.pi / pulses_per_rev ** 1.5


def pitch_pattern(config: SpeedSensorConfig, seed: int) -> np.ndarray:
    """Draw the pitch errors delta_k [rad] of the edges k = 0..pulses_per_rev-1 from ``seed``.

    See the module docstring; empty when there are none (``pitch_error`` 0, or one pulse per
    revolution).
    """
    n = config.pulses_per_rev
    if config.pitch_error == 0.0 or n < 2:
        return np.zeros(0)
    z = np.random.default_rng([seed, PITCH_SEED_STREAM]).standard_normal(n)
    z -= z.mean()
    return z * (config.pitch_error / math.sqrt(np.mean(z * z)))


def fg_speed(period_ticks: int, config: SpeedSensorConfig) -> float:
    """Return the speed [rad/s] read from a pulse period of ``period_ticks`` timer ticks."""
    return _fg_speed(period_ticks, config.timer_hz, config.pulses_per_rev)


@kernel
def _fg_speed(period_ticks, timer_hz, pulses_per_rev):
    return 2.0 * math.pi * timer_hz / (pulses_per_rev * period_ticks)


@kernel
def _hermite_crossing(level, h, th0, w0, th1, w1) -> float:
    """Return the time s in [0, h] at which a cubic Hermite interpolant equals ``level``.

    The interpolant of (th0, w0) at 0 and (th1, w1) at h; ``level`` lies between th0 and th1.
    """
    d = th1 - th0
    u = (level - th0) / d if d != 0.0 else 0.0   # linear guess, u = s / h
    hw0, hw1 = h * w0, h * w1
    for _ in range(_NEWTON_ITERATIONS):
        u2 = u * u
        u3 = u2 * u
        value = ((2 * u3 - 3 * u2 + 1) * th0 + (u3 - 2 * u2 + u) * hw0
                 + (3 * u2 - 2 * u3) * th1 + (u3 - u2) * hw1)
        slope = ((6 * u2 - 6 * u) * (th0 - th1) + (3 * u2 - 4 * u + 1) * hw0
                 + (3 * u2 - 2 * u) * hw1)          # d value / du
        if slope == 0.0:
            break
        correction = (value - level) / slope
        u = min(max(u - correction, 0.0), 1.0)
        if abs(correction) < 1e-13:
            break
    return u * h


class SpeedSensor:
    """The FG reading at each state sample (see the module docstring).

    :meth:`update` takes the state samples in time order and returns the held reading.
    """

    def __init__(self, config: SpeedSensorConfig | None = None, seed: int = 0):
        self.config = config or SpeedSensorConfig()
        self.seed = seed
        self.reset()

    def reset(self) -> None:
        """Re-seed and forget every edge: the readings repeat from the start."""
        self.rng = np.random.default_rng([self.seed, SPEED_SEED_STREAM])
        self._last = None          # (t, theta, omega) of the previous sample
        self._state = np.zeros(N_STATE)
        self._jitter = NormalStream(self.rng)
        self._offsets = pitch_pattern(self.config, self.seed)

    @property
    def pitch_offsets(self) -> np.ndarray:
        """The pitch errors delta_k [rad] of edges k = 0..pulses_per_rev-1 (empty: none)."""
        return self._offsets.copy()

    @property
    def min_speed(self) -> float:
        """The lowest steady speed [rad/s] at which an edge comes within the timeout.

        Below it the reading drops to 0 between edges. 2 pi / (pulses_per_rev * timeout)
        without pitch error; with one, the widest edge interval sets it.
        """
        c, d = self.config, self._offsets
        widest = c.pitch + (float(np.max(d - np.roll(d, 1))) if d.size else 0.0)
        return widest / c.timeout

    def state(self, omega: float) -> str:
        """Return one of :data:`FG_STATES` for the true spindle speed ``omega`` [rad/s].

        The state also depends on the present reading.
        """
        speed, low = abs(omega), self.min_speed
        if speed < STOPPED_FRACTION * low:
            return 'stopped'
        if speed < low:
            return 'below_min_speed'
        return 'measuring' if self._state[VALUE] > 0.0 else 'waiting_for_edges'

    @property
    def value(self) -> float:
        """The held reading [rad/s]."""
        return float(self._state[VALUE])

    @property
    def edges(self) -> int:
        """Edges captured since the last reset."""
        return int(self._state[EDGES])

    def reconfigure(self, config: SpeedSensorConfig) -> None:
        """Apply new settings.

        A new pulse count restarts the edge bookkeeping (not the seed); a new pulse count or
        pitch error redraws the pitch pattern from the seed.
        """
        old, self.config = self.config, config
        if config.pulses_per_rev != old.pulses_per_rev:
            self._last = None
            self._state[[EDGE_TICKS, EDGE_T, VALUE, HAS_EDGE]] = 0.0
        if (config.pulses_per_rev, config.pitch_error) != (old.pulses_per_rev, old.pitch_error):
            self._offsets = pitch_pattern(config, self.seed)

    def shift_angle(self, delta: float) -> None:
        """Follow the state's theta re-expressed by ``delta`` [rad] without the rotor moving.

        A disc swap (:func:`abb_ros.model.sensors.disturbances.swap_disc`): no edge is produced.
        """
        if self._last is not None:
            t, theta, omega = self._last
            self._last = (t, theta + delta, omega)

    def update(self, t: float, theta: float, omega: float) -> float:
        """Return the reading [rad/s] after the state sample (t, theta, omega).

        Advances the jitter generator once per edge crossed since the preceding sample.
        """
        last, self._last = self._last, (t, theta, omega)
        state = self._state
        if last is not None and t > last[0]:
            c, offsets = self.config, self._offsets
            edges = abs(_edge_index(theta, c.pitch, offsets)
                        - _edge_index(last[1], c.pitch, offsets))
            if edges:
                JIT.fg_edges(last, self._last, c.pitch, offsets, c.timer_hz, c.pulses_per_rev,
                             c.edge_jitter, self._jitter.take(edges), state)
        if state[HAS_EDGE] and t - state[EDGE_T] > self.config.timeout:
            state[VALUE] = 0.0
        return float(state[VALUE])


@kernel
def _edge_index(theta, pitch, offsets):
    """Return the index k of the last FG edge at or below the rotor angle ``theta``.

    Edge k is at k * pitch + offsets[k mod n] (n = offsets.size, each |offset| < pitch / 2),
    or at k * pitch when ``offsets`` is empty.
    """
    k = math.floor(theta / pitch)
    n = offsets.size
    if n == 0:
        return k
    if k * pitch + offsets[k % n] > theta:
        return k - 1
    if (k + 1) * pitch + offsets[(k + 1) % n] <= theta:
        return k + 1
    return k


@kernel
def fg_edges(a, b, pitch, offsets, timer_hz, pulses_per_rev, edge_jitter, normals, state):
    """Capture every FG edge between the state samples a = (t0, theta0, omega0) and b.

    b is a later sample. Each crossing of an edge angle k * pitch + offsets[k mod
    pulses_per_rev] (k * pitch when ``offsets`` is empty; in the order the rotor meets them)
    is found on the Hermite interpolant, jittered by its own of ``normals`` (one per edge, in
    order) times ``edge_jitter`` and captured by the timer; ``state`` (EDGE_TICKS...) is
    updated.
    """
    t0, th0, w0 = a[0], a[1], a[2]
    t1, th1, w1 = b[0], b[1], b[2]
    k0, k1 = _edge_index(th0, pitch, offsets), _edge_index(th1, pitch, offsets)
    step = 1 if k1 > k0 else -1
    first = k0 + 1 if k1 > k0 else k0
    h = t1 - t0
    n = offsets.size
    for i in range(abs(k1 - k0)):
        k = first + step * i
        level = k * pitch if n == 0 else k * pitch + offsets[k % n]
        s = _hermite_crossing(level, h, th0, w0, th1, w1)
        t_edge = t0 + s
        ticks = math.floor((t_edge + normals[i] * edge_jitter) * timer_hz)
        if state[HAS_EDGE] != 0.0 and ticks > state[EDGE_TICKS]:
            state[VALUE] = _fg_speed(ticks - state[EDGE_TICKS], timer_hz, pulses_per_rev)
        state[EDGE_TICKS] = ticks
        state[EDGE_T] = t_edge
        state[HAS_EDGE] = 1.0
        state[EDGES] += 1.0


JIT, PY = kernel.build()
"""The FG's kernels compiled (numba) and as Python (see abb_ros.model.jit)."""
