"""rosbag2's ``metadata.yaml`` layout: offered QoS profiles and the YAML text yaml-cpp writes.

The bag writer (:mod:`abb_ros.io.bag.writer`) writes its metadata and each channel's
``offered_qos_profiles`` with these, so that ``ros2 bag info`` and rosbag2's reader take
them as their own.
"""

from __future__ import annotations

import yaml

__all__ = ['default_qos', 'qos_dict', 'dump_yaml']

# rmw's RMW_DURATION_INFINITE as the graph reports it (INT64_MAX ns).
_INFINITE = {'sec': 9223372036, 'nsec': 854775807}


def default_qos() -> dict:
    """Return the QoS an rclpy publisher with depth 10 offers, as the ROS graph reports it.

    As Fast DDS reports it: history unknown, depth 0, everything else rclpy's default.
    """
    return {'history': 'unknown', 'depth': 0, 'reliability': 'reliable',
            'durability': 'volatile', 'deadline': dict(_INFINITE),
            'lifespan': dict(_INFINITE), 'liveliness': 'automatic',
            'liveliness_lease_duration': dict(_INFINITE),
            'avoid_ros_namespace_conventions': False}


def qos_dict(profile) -> dict:
    """Convert an offered rclpy ``QoSProfile`` to rosbag2's metadata v9 form."""
    if isinstance(profile, dict):
        return dict(profile)

    def duration(d):
        sec, nsec = divmod(int(d.nanoseconds), 1_000_000_000)
        return {'sec': sec, 'nsec': nsec}

    return {'history': profile.history.name.lower(), 'depth': int(profile.depth),
            'reliability': profile.reliability.name.lower(),
            'durability': profile.durability.name.lower(),
            'deadline': duration(profile.deadline), 'lifespan': duration(profile.lifespan),
            'liveliness': profile.liveliness.name.lower(),
            'liveliness_lease_duration': duration(profile.liveliness_lease_duration),
            'avoid_ros_namespace_conventions': bool(profile.avoid_ros_namespace_conventions)}


class _Dumper(yaml.SafeDumper):
    """yaml-cpp's layout: block style, sequences indented under their key, '' as ""."""

    def increase_indent(self, flow=False, indentless=False):  # noqa: ARG002
        # PyYAML's signature; indentless is ignored on purpose: sequences indent under keys
        return super().increase_indent(flow, False)


def _str(dumper, value):
    style = '"' if not value else None
    return dumper.represent_scalar('tag:yaml.org,2002:str', value, style=style)


_Dumper.add_representer(str, _str)


def dump_yaml(data) -> str:
    """Return YAML text in the layout rosbag2 (yaml-cpp) writes, without the final newline."""
    text = yaml.dump(data, Dumper=_Dumper, default_flow_style=False, sort_keys=False, width=4096)
    return text.replace(': null\n', ': ~\n').rstrip('\n')
