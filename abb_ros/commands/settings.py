"""Which parameters each ``abb-sim`` subcommand takes with ``--set``.

The specs themselves are the model's (:mod:`abb_ros.model.parameters`); the command line says
which of them it takes. Every subcommand with ``--set`` takes the drive (SI names, without
``drive.``) and the operating speed ``omega``; ``run`` takes the plant's rates, spindle, seed
and IMU too (not ``max_spindle_speed``, a node's limit, nor ``motor.*``, torque mode being a
node's).
"""

from __future__ import annotations

from abb_ros.model.parameters.drive_spec import DRIVE_SPECS, SPEED_SPEC
from abb_ros.model.parameters.param_spec import ParamSpec
from abb_ros.model.parameters.plant_spec import IMU_SPECS, SEED, SPINDLE_SPECS, STEP_SPECS

__all__ = ['SET_SPECS', 'spec_for_command', 'cli_names', 'commands_taking']

SET_SPECS: dict[str, tuple[ParamSpec, ...]] = {
    'run': DRIVE_SPECS + STEP_SPECS + SPINDLE_SPECS + (SEED,) + IMU_SPECS,
    'stability': DRIVE_SPECS,
    'freqs': DRIVE_SPECS,
    'map': DRIVE_SPECS,
}
"""{subcommand: the specs its ``--set`` takes}; each also takes the operating speed
(:data:`~abb_ros.model.parameters.drive_spec.SPEED_SPEC`, ``omega`` or an Eq. (39) ``wbar``),
which the drive's parameters parse."""


def spec_for_command(command: str, name: str) -> ParamSpec | None:
    """Return the spec ``--set name=...`` of ``abb-sim command`` refers to (drive: SI name)."""
    for s in SET_SPECS.get(command, ()):
        if name in (s.short, s.name):
            return s
    return None


def cli_names(command: str) -> list[str]:
    """Return the names ``abb-sim command --set`` accepts (besides omega and Eq. 39 names)."""
    return [s.short for s in SET_SPECS.get(command, ())]


def commands_taking(spec: ParamSpec) -> tuple[str, ...]:
    """Return the subcommands whose ``--set`` takes ``spec``, in :data:`SET_SPECS` order."""
    return tuple(command for command, specs in SET_SPECS.items()
                 if spec is SPEED_SPEC or spec in specs)
