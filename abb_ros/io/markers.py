"""visualization_msgs/MarkerArray of the drive for RViz and Foxglove 3D panels.

Markers, all in frame ``base`` (the frame of ``deck/pose``), namespace ``abb``:

- id 0, the deck: a CUBE a x b (x by y in deck axes) and ``DECK_THICKNESS`` thick, centred on
  the deck's mass centre P = C + (0, -d, 0) (deck axes), below the rotor;
- id 1, the rotor: a CYLINDER of radius R + ``BALL`` radius, ``ROTOR_HEIGHT`` high, on the
  spin axis through C;
- ids 2..n+1, the balls: SPHEREs of a steel ball of mass m (density ``STEEL_DENSITY``) at
  radius R and angle theta + phi_i from the deck's x axis (the kernel's convention), at mid
  height of the rotor.

The deck's displacement (X, Y, Z) and its angles (alpha, beta, gamma) are multiplied by
``exaggeration`` before drawing (the real ones are micrometres and milliradians); the rotor
and the balls ride on the exaggerated deck; the ball angles are not scaled.
"""

from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import Pose
from visualization_msgs.msg import Marker, MarkerArray

from abb_ros.io.ros_messages import FRAME_BASE, time_msg
from abb_ros.model.dynamics import n_coords
from abb_ros.model.params import DriveParams
from abb_ros.model.sensors import euler_quaternion, euler_rotation

__all__ = ['NAMESPACE', 'DECK_THICKNESS', 'ROTOR_HEIGHT', 'STEEL_DENSITY', 'ball_radius',
           'marker_poses', 'marker_array']

NAMESPACE = 'abb'
DECK_THICKNESS = 2e-3   # [m], drawing only
ROTOR_HEIGHT = 8e-3     # [m], drawing only
STEEL_DENSITY = 7850.0  # [kg/m^3]
_COLOURS = {Marker.CUBE: (0.55, 0.55, 0.6, 1.0), Marker.CYLINDER: (0.2, 0.4, 0.8, 0.6),
            Marker.SPHERE: (0.9, 0.3, 0.1, 1.0)}


def ball_radius(m: float) -> float:
    """Radius [m] of a steel ball of mass m [kg]."""
    return (3.0 * m / (4.0 * math.pi * STEEL_DENSITY)) ** (1.0 / 3.0)


def marker_poses(y: np.ndarray, params: DriveParams, exaggeration: float
                 ) -> list[tuple[int, tuple[float, ...], tuple[float, float, float]]]:
    """[(marker type, (x, y, z, qx, qy, qz, qw) in base, (scale x, y, z))] for the deck,
    the rotor and the n balls, in id order."""
    n = params.n
    N = n_coords(n)
    k = exaggeration
    c = k * np.asarray(y[1:4], dtype=float)
    angles = (k * float(y[4]), k * float(y[5]), k * float(y[6]))
    rotation = euler_rotation(*angles)
    quat = euler_quaternion(*angles)
    r_ball = ball_radius(params.m)

    def at(point_deck):
        return tuple((c + rotation @ np.asarray(point_deck)).tolist()) + quat

    out = [(Marker.CUBE, at((0.0, -params.d, -DECK_THICKNESS / 2)),
            (params.a, params.b, DECK_THICKNESS)),
           (Marker.CYLINDER, at((0.0, 0.0, ROTOR_HEIGHT / 2)),
            (2 * (params.R + r_ball),) * 2 + (ROTOR_HEIGHT,))]
    theta = float(y[0])
    for phi in y[7:N]:
        psi = theta + float(phi)
        out.append((Marker.SPHERE,
                    at((params.R * math.cos(psi), params.R * math.sin(psi), ROTOR_HEIGHT / 2)),
                    (2 * r_ball,) * 3))
    return out


def marker_array(stamp_ns: int, y: np.ndarray, params: DriveParams, exaggeration: float,
                 out: MarkerArray | None = None) -> MarkerArray:
    """The MarkerArray of :func:`marker_poses` (see the module docstring).

    ``out``: a MarkerArray from an earlier call, filled in place when it has the same number
    of markers (the generated constructors cost more than the rest)."""
    stamp = time_msg(stamp_ns)
    poses = marker_poses(y, params, exaggeration)
    if out is None or len(out.markers) != len(poses):
        out = MarkerArray(markers=[_new_marker(i, kind) for i, (kind, _, _) in enumerate(poses)])
    for m, (kind, pose, scale) in zip(out.markers, poses):
        m.header.stamp = stamp
        p, o = m.pose.position, m.pose.orientation
        p.x, p.y, p.z, o.x, o.y, o.z, o.w = pose
        m.scale.x, m.scale.y, m.scale.z = scale
    return out


def _new_marker(i: int, kind: int) -> Marker:
    m = Marker(ns=NAMESPACE, id=i, type=kind, action=Marker.ADD, frame_locked=False)
    m.header.frame_id = FRAME_BASE
    m.pose = Pose()
    m.color.r, m.color.g, m.color.b, m.color.a = _COLOURS[kind]
    return m
