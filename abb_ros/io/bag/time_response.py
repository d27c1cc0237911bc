"""A bag's time response: the deck coordinates and the ball angles over time, as arrays.

:func:`load_time_response` reads them from a bag (ours, or ``ros2 bag record`` of our topics):
deck/pose and joint_states of any namespace, stamped with the simulated time. The figures of
the paper are drawn from it by :mod:`abb_ros.plots.time_response`. All values are SI.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np

from abb_ros.io.bag.reader import read_bag, read_drive_params
from abb_ros.io.wire.topics import DECK_POSE, JOINT_STATES
from abb_ros.model.dynamics.state import rbar
from abb_ros.model.parameters.params import DriveParams

__all__ = ['TimeResponse', 'TimeResponseError', 'euler_from_quaternion', 'load_time_response']

_BALL = re.compile(r'^ball_(\d+)$')


class TimeResponseError(ValueError):
    """The bag lacks what a time response needs (deck/pose), or R is not positive."""


@dataclasses.dataclass
class TimeResponse:
    """Deck coordinates and ball angles over time. All values are SI (s, m, rad).

    t_pose : shape (T,); deck : shape (6, T) = X, Y, Z, alpha, beta, gamma (Eqs. 1-2 sequence);
    t_joint : shape (S,); phi : shape (n, S), ball angles from the imbalance G; R : race radius.
    """

    t_pose: np.ndarray
    deck: np.ndarray
    t_joint: np.ndarray
    phi: np.ndarray
    R: float
    R_source: str

    @property
    def rbar(self) -> np.ndarray:
        """Deck translation over the race radius, sqrt(X^2 + Y^2 + Z^2) / R (Fig. 9(a))."""
        return rbar(*self.deck[:3], self.R)


def euler_from_quaternion(x, y, z, w):
    """Return (alpha, beta, gamma) of a quaternion's R = Rz(gamma) Rx(alpha) Ry(beta), Eqs. 1-2."""
    x, y, z, w = (np.asarray(v, dtype=float) for v in (x, y, z, w))
    r01 = 2.0 * (x * y - w * z)
    r11 = 1.0 - 2.0 * (x * x + z * z)
    r20 = 2.0 * (x * z - w * y)
    r21 = 2.0 * (y * z + w * x)
    r22 = 1.0 - 2.0 * (x * x + y * y)
    alpha = np.arcsin(np.clip(r21, -1.0, 1.0))
    beta = np.arctan2(-r20, r22)
    gamma = np.arctan2(-r01, r11)
    return alpha, beta, gamma


def _stamp(msg, log_time):
    """Return the header stamp (simulated time) when set, else the receive time [ns]."""
    ns = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
    return ns if ns else log_time


def load_time_response(path, R: float | None = None) -> TimeResponse:
    """Read deck/pose and joint_states (any namespace) of a bag.

    R: the drive parameters stored in the bag, else ``R``, else Table 1 (0.015 m).
    """
    pose_t, pose = [], []
    joint_t, joint = [], []
    names = None
    for topic, msg, log_time in read_bag(path):
        if topic.endswith('/' + DECK_POSE):
            p, q = msg.pose.position, msg.pose.orientation
            pose_t.append(_stamp(msg, log_time))
            pose.append((p.x, p.y, p.z, q.x, q.y, q.z, q.w))
        elif topic.endswith('/' + JOINT_STATES):
            if names is None:
                names = sorted((int(m.group(1)), i) for i, n in enumerate(msg.name)
                               if (m := _BALL.match(n)))
            if len(msg.position) == len(msg.name):
                joint_t.append(_stamp(msg, log_time))
                joint.append([msg.position[i] for _, i in names])
    if not pose:
        raise TimeResponseError(f'{path} has no deck/pose messages: rbar and the deck coordinates '
                        'need them')
    stored = read_drive_params(path) or {}
    if 'R' in stored:
        radius, source = float(stored['R']), 'bag'
    elif R is not None:
        radius, source = float(R), '--R'
    else:
        radius, source = DriveParams().R, 'Table 1'
    if not radius > 0:
        raise TimeResponseError(f'R must be > 0 m, got {radius}')
    pose = np.asarray(pose, dtype=float)
    t0 = min(pose_t[0], joint_t[0]) if joint_t else pose_t[0]
    deck = np.vstack([pose[:, :3].T, np.vstack(euler_from_quaternion(*pose[:, 3:].T))])
    phi = np.asarray(joint, dtype=float).T if joint else np.zeros((0, 0))
    return TimeResponse(t_pose=(np.asarray(pose_t) - t0) * 1e-9, deck=deck,
                        t_joint=(np.asarray(joint_t) - t0) * 1e-9, phi=phi, R=radius,
                        R_source=source)
