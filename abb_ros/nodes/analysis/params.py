"""The analysis node's own parameters (besides ``drive.*`` and ``max_spindle_speed``).

The node declares the drive's parameters and ``max_spindle_speed``
(:mod:`abb_ros.model.parameters.drive_spec`, :mod:`abb_ros.model.parameters.plant_spec`) and copies
them from the simulator it follows; :data:`ANALYSIS_SPECS` are the ones only it has.
"""

from __future__ import annotations

from abb_ros.model.parameters.param_spec import INTEGER, STRING, ParamSpec

__all__ = ['ANALYSIS_SPECS']


ANALYSIS_SPECS = (
    ParamSpec('simulator_node', 'abb_simulator', '', 'node whose drive.* and max_spindle_speed '
              'are followed (relative names resolve in this node\'s namespace)', STRING,
              read_only=True, applies='at start-up'),
    ParamSpec('publish_rate_hz', 50.0, 'Hz', 'largest rate of stability/margin and the status',
              low=0.1, high=1000.0, applies='at once'),
    ParamSpec('heartbeat_s', 1.0, 's', 'status republished at least this often', low=0.01,
              high=3600.0, applies='at once'),
    ParamSpec('table_points', 300, '', 'speeds in the |lambda|max table over '
              '0..max_spindle_speed', INTEGER, 16, 20000, applies='at once'),
)
"""Parameters only the analysis node has."""
