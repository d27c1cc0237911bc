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

__all__ = ['SpeedSensorConfig', 'SpeedSensor', 'fg_speed', 'SPEED_SEED_STREAM']

SPEED_SEED_STREAM = 1
"""Second seed word of the FG's generator: ``default_rng([seed, 1])``, so its jitter is
independent of the IMU noise drawn from ``default_rng(seed)``."""

_NEWTON_ITERATIONS = 4


@dataclass(frozen=True)
class SpeedSensorConfig:
    """FG pulses per revolution, capture timer clock [Hz], edge jitter std [s], zero-speed
    timeout [s]."""

    pulses_per_rev: int = 6
    timer_hz: float = 1.0e6
    edge_jitter: float = 1.0e-6
    timeout: float = 0.1

    @property
    def pitch(self) -> float:
        """Rotor angle between two FG edges [rad]."""
        return 2.0 * math.pi / self.pulses_per_rev


def fg_speed(period_ticks: int, config: SpeedSensorConfig) -> float:
    """The speed [rad/s] read from a pulse period of ``period_ticks`` timer ticks."""
    return 2.0 * math.pi * config.timer_hz / (config.pulses_per_rev * period_ticks)


def _hermite_crossing(level, h, th0, w0, th1, w1) -> float:
    """Time s in [0, h] at which the cubic Hermite interpolant of (th0, w0) at 0 and
    (th1, w1) at h equals ``level`` (which lies between th0 and th1)."""
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
        self._edge_ticks = None    # tick count of the last captured edge
        self._edge_t = None        # its time [s]
        self.value = 0.0
        self.edges = 0

    def reconfigure(self, config: SpeedSensorConfig) -> None:
        """New settings; a new pulse count restarts the edge bookkeeping (not the seed)."""
        if config.pulses_per_rev != self.config.pulses_per_rev:
            self._last = self._edge_ticks = self._edge_t = None
            self.value = 0.0
        self.config = config

    def shift_angle(self, delta: float) -> None:
        """The state's theta was re-expressed by ``delta`` [rad] without the rotor moving
        (a disc swap, :func:`abb_ros.model.disturbances.swap_disc`): no edge is produced."""
        if self._last is not None:
            t, theta, omega = self._last
            self._last = (t, theta + delta, omega)

    def update(self, t: float, theta: float, omega: float) -> float:
        """The reading [rad/s] after the state sample (t, theta, omega); advances the jitter
        generator once per edge crossed since the previous sample."""
        last, self._last = self._last, (t, theta, omega)
        if last is not None and t > last[0]:
            self._edges_between(last, (t, theta, omega))
        if self._edge_t is not None and t - self._edge_t > self.config.timeout:
            self.value = 0.0
        return self.value

    def _edges_between(self, a, b) -> None:
        c = self.config
        (t0, th0, w0), (t1, th1, w1) = a, b
        k0, k1 = math.floor(th0 / c.pitch), math.floor(th1 / c.pitch)
        if k1 > k0:
            levels = range(k0 + 1, k1 + 1)
        elif k1 < k0:           # turning backwards: the edges in reverse order
            levels = range(k0, k1, -1)
        else:
            return
        h = t1 - t0
        for k in levels:
            s = _hermite_crossing(k * c.pitch, h, th0, w0, th1, w1)
            self._capture(t0 + s)

    def _capture(self, t_edge: float) -> None:
        c = self.config
        jitter = self.rng.standard_normal() * c.edge_jitter
        ticks = math.floor((t_edge + jitter) * c.timer_hz)
        if self._edge_ticks is not None and ticks > self._edge_ticks:
            self.value = fg_speed(ticks - self._edge_ticks, c)
        self._edge_ticks = ticks
        self._edge_t = t_edge
        self.edges += 1
