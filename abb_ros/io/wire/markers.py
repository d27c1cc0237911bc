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
from visualization_msgs.msg import Marker

from abb_ros.io.wire.cdr import Layout
from abb_ros.io.wire.ros_messages import FRAME_BASE
from abb_ros.model.dynamics.equations import n_coords
from abb_ros.model.parameters.params import DriveParams
from abb_ros.model.sensors.imu import euler_quaternion, euler_rotation

__all__ = ['NAMESPACE', 'DECK_THICKNESS', 'ROTOR_HEIGHT', 'STEEL_DENSITY', 'ball_radius',
           'marker_poses', 'marker_array']

NAMESPACE = 'abb'
DECK_THICKNESS = 2e-3   # [m], drawing only
ROTOR_HEIGHT = 8e-3     # [m], drawing only
STEEL_DENSITY = 7850.0  # [kg/m^3]
_COLOURS = {Marker.CUBE: (0.55, 0.55, 0.6, 1.0), Marker.CYLINDER: (0.2, 0.4, 0.8, 0.6),
            Marker.SPHERE: (0.9, 0.3, 0.1, 1.0)}


def ball_radius(m: float) -> float:
    """Return the radius [m] of a steel ball of mass m [kg]."""
    return (3.0 * m / (4.0 * math.pi * STEEL_DENSITY)) ** (1.0 / 3.0)


def marker_poses(y: np.ndarray, params: DriveParams, exaggeration: float
                 ) -> list[tuple[int, tuple[float, ...], tuple[float, float, float]]]:
    """Return the markers of the deck, the rotor and the n balls, in id order.

    [(marker type, (x, y, z, qx, qy, qz, qw) in base, (scale x, y, z))].
    """
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

    race = params.z_B + ROTOR_HEIGHT / 2       # the race (and the rotor drawn around it) at z_B
    out = [(Marker.CUBE, at((0.0, -params.d, -DECK_THICKNESS / 2)),
            (params.a, params.b, DECK_THICKNESS)),
           (Marker.CYLINDER, at((0.0, 0.0, race)),
            (2 * (params.R + r_ball),) * 2 + (ROTOR_HEIGHT,))]
    theta = float(y[0])
    for phi in y[7:N]:
        psi = theta + float(phi)
        out.append((Marker.SPHERE,
                    at((params.R * math.cos(psi), params.R * math.sin(psi), race)),
                    (2 * r_ball,) * 3))
    return out


def _marker_layout(kinds: tuple[int, ...]):
    """Compile the CDR layout of a MarkerArray of markers of ``kinds`` (ids 0, 1, ...).

    Per marker the variable stamp, then pose (7 doubles) and scale (3 doubles); every other
    field constant (ADD, colour of the kind, lifetime 0, no points, texture, mesh or text).
    """
    layout = Layout().const('I', len(kinds))
    for i, kind in enumerate(kinds):
        layout.var('i').var('I').string(FRAME_BASE)                 # header
        layout.string(NAMESPACE).const('i', i, kind, Marker.ADD)    # ns, id, type, action
        layout.var('d', 10)                                         # pose, scale
        layout.const('f', *_COLOURS[kind]).const('i', 0).const('I', 0)    # color, lifetime
        layout.const('B', 0).const('I', 0, 0)                       # frame_locked, points, colors
        layout.string('')                                           # texture_resource
        layout.const('i', 0).const('I', 0).string('').string('').const('I', 0)   # texture
        layout.const('I', 0).string('').string('')                  # uv, text, mesh_resource
        layout.string('').const('I', 0).const('B', 0)               # mesh_file, embedded
    return layout.compile()


_LAYOUTS: dict[tuple[int, ...], object] = {}


def marker_array(stamp_ns: int, y: np.ndarray, params: DriveParams, exaggeration: float
                 ) -> bytes:
    """Return the CDR bytes of the visualization_msgs/MarkerArray of :func:`marker_poses`.

    See the module docstring. They are published as they are (no rclpy message is built:
    converting a MarkerArray of twelve markers costs more than the rest of the node's publish
    period).
    """
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    poses = marker_poses(y, params, exaggeration)
    kinds = tuple(kind for kind, _, _ in poses)
    if kinds not in _LAYOUTS:
        _LAYOUTS[kinds] = _marker_layout(kinds)
    st, consts = _LAYOUTS[kinds]
    args = []
    for (_, pose, scale), head, body in zip(poses, consts[0::2], consts[1::2]):
        args += (head, sec, nanosec, body, *pose, *scale)
    args.append(consts[-1])
    return st.pack(*args)
