"""Every parameter of abb_ros, and which node declares which.

The drive's (:mod:`abb_ros.model.parameters.drive_spec`) and the plant's
(:mod:`abb_ros.model.parameters.plant_spec`) live in the model, each node's own beside the node
(``abb_ros/nodes/<node>_params.py``); the specs name no node. This module says which node
declares which: :data:`NODE_SPECS`, :func:`specs_for` (what a node declares, in order),
:func:`nodes_taking`; and :func:`markdown` writes the table of docs/parameters.md
(``python scripts/make_parameters_doc.py > docs/parameters.md``).
"""
from __future__ import annotations

from typing import Iterable

from abb_ros.model.parameters.drive_spec import DRIVE_SPECS
from abb_ros.model.parameters.param_spec import ParamSpec
from abb_ros.model.parameters.plant_spec import MAX_SPINDLE_SPEED, MOTOR_SPECS
from abb_ros.nodes.analysis.params import ANALYSIS_SPECS
from abb_ros.nodes.recorder.params import RECORDER_SPECS
from abb_ros.nodes.simulator.params import SIMULATOR_SPECS
from abb_ros.nodes.spin_controller.params import CONTROLLER_SPECS

__all__ = ['NODES', 'SPECS', 'NODE_SPECS', 'specs_for', 'nodes_taking', 'markdown']

NODES = ('simulator', 'analysis', 'recorder', 'spin_controller')
"""Executables with ROS parameters (``ros2 run abb_ros <node>``)."""

SPECS = DRIVE_SPECS + SIMULATOR_SPECS + ANALYSIS_SPECS + RECORDER_SPECS + CONTROLLER_SPECS
"""Every parameter. A name may appear twice for different nodes (publish_rate_hz)."""

NODE_SPECS: dict[str, tuple[ParamSpec, ...]] = {
    'simulator': DRIVE_SPECS + SIMULATOR_SPECS,
    'analysis': DRIVE_SPECS + (MAX_SPINDLE_SPEED,) + ANALYSIS_SPECS,
    'recorder': RECORDER_SPECS,
    'spin_controller': DRIVE_SPECS + (MAX_SPINDLE_SPEED,) + MOTOR_SPECS + CONTROLLER_SPECS,
}
"""{node: the specs it declares, in order}: the drive's for every node that models it, the
plant's for the simulator, the motor's also for the controller (torque mode), and each
node's own."""


def specs_for(node: str) -> dict[str, ParamSpec]:
    """Return {ROS name: spec} of the parameters ``node`` (one of NODES) declares, in order."""
    return {s.name: s for s in NODE_SPECS[node]}


def nodes_taking(spec: ParamSpec) -> tuple[str, ...]:
    """Return the nodes that declare ``spec``, in :data:`NODES` order."""
    return tuple(node for node in NODES if any(s is spec for s in NODE_SPECS[node]))


def _default_text(spec: ParamSpec) -> str:
    if spec.default is None:
        return '(computed)'
    if isinstance(spec.default, bool):
        return str(spec.default).lower()
    if isinstance(spec.default, str):
        return f"'{spec.default}'"
    if isinstance(spec.default, list):
        return '[' + ', '.join(_default_text(ParamSpec('', x, '', '')) for x in
                               spec.default) + ']'
    return f'{spec.default:g}' if isinstance(spec.default, float) else str(spec.default)


def _table(specs: Iterable[ParamSpec], commands_of) -> list[str]:
    rows = ['| name | type | default | valid | applies | `abb-sim --set` | description |',
            '|---|---|---|---|---|---|---|']
    for s in specs:
        applies = s.applies + (' (read-only)' if s.read_only else '')
        cli = ', '.join(commands_of(s)) or '-'
        rows.append(f'| `{s.name}` | {s.type} | {_default_text(s)} | {s.valid_text()} | '
                    f'{applies} | {cli} | {s.description.replace("|", chr(92) + "|")} |')
    return rows


def markdown(commands_of) -> str:
    """Return docs/parameters.md: one table per node, generated from SPECS.

    ``commands_of(spec)`` gives the ``abb-sim`` subcommands whose ``--set`` takes a spec (the
    command line's mapping, :func:`abb_ros.commands.settings.commands_taking`).

    Returns
    -------
    str
        The whole Markdown text.
    """
    lines = ['# Parameters', '',
             'Generated from the parameter specs (the drive\'s and the plant\'s in',
             '`abb_ros/model/parameters/drive_spec.py` and',
             '`abb_ros/model/parameters/plant_spec.py`, each node\'s',
             'own in `abb_ros/nodes/<node>_params.py`) by',
             '`python scripts/make_parameters_doc.py > docs/parameters.md`;',
             'do not edit by hand (test/model/parameters/test_param_spec.py compares).', '',
             'Ranges: `[` `]` include the bound, `(` `)` exclude it. ROS nodes take the '
             'parameters with `--ros-args -p name:=value` or `--params-file` '
             '(config/cdrom_table1.yaml, config/simulator.yaml); an integer literal for a '
             'double is taken as that double, at start-up and at run time. Invalid values '
             'or types at start-up end the node with exit code 2 and one line naming the '
             'parameter; at run time an invalid value is refused with the same text (a wrong '
             'type with rclpy\'s type error). '
             '`abb-sim` subcommands take the names in the `abb-sim --set` column (drive '
             'parameters without `drive.`), besides `omega` [rad/s] and the Eq. (39) names '
             'wbar, zeta, Dbar, epsbar, mbar.', '']
    titles = {'drive': 'Drive (`drive.*`, simulator, analysis and controller nodes)',
              'simulator': 'Simulator node (`abb_simulator`)',
              'analysis': 'Analysis node (`abb_analysis`)',
              'recorder': 'Recorder node (`abb_recorder`)',
              'controller': 'Example controller (`abb_spin_controller`, executable '
                            '`spin_controller`)'}
    groups = {'drive': DRIVE_SPECS, 'simulator': SIMULATOR_SPECS,
              'analysis': ANALYSIS_SPECS, 'recorder': RECORDER_SPECS,
              'controller': CONTROLLER_SPECS}
    for key, specs in groups.items():
        lines += ['## ' + titles[key], ''] + _table(specs, commands_of) + ['']
    lines += _limits(commands_of)
    lines.append('The analysis node and the example controller also declare `drive.*` and '
                 '`max_spindle_speed` (above); the analysis node copies them from the '
                 'simulator it follows; the example controller also declares `motor.*` '
                 '(simulator, above), which must be the simulator\'s in torque mode.')
    return '\n'.join(lines) + '\n'


def _limits(commands_of) -> list[str]:
    """Return the section on the operating speed and the work limits of ``abb-sim``."""
    from abb_ros.model.dynamics.integrate import MAX_RUN_STEPS
    from abb_ros.model.parameters.drive_spec import CLAMPED_DECK, SPAN, SPEED_SPEC
    from abb_ros.model.stability.floquet import MAX_STEPS
    head = ['## Operating point and work limits (`abb-sim`)', '']
    return head + _table([SPEED_SPEC], commands_of) + [
        '', f'Each drive parameter above lies within a factor of {SPAN:.0e} of its Table 1 '
        'value (of a typical value where the default is 0; the deck\'s mass and inertias up '
        f'to {CLAMPED_DECK:.0e}, a deck clamped by its mass): wider than any optical '
        'drive, narrow enough that the analysis keeps its digits. Work that grows with the '
        'input is limited, and checked before it starts: at most '
        f'{MAX_STEPS} RK4 steps per period of one Floquet point (`stability`, `map`, the '
        f'sweeps; a speed far below the resonances is refused) and at most {MAX_RUN_STEPS} '
        'steps per run (`run --duration`, duration / dt); docs/cli.md lists the others.', '']
