"""ROS parameters from the parameter specs: descriptors, declaring, int -> double coercion.

Also the simulator's validated settings. The specs are collected by
:mod:`abb_ros.nodes.ros.parameter_table`.

:func:`declare` declares a node's parameters with descriptors derived from their specs. It
reads the start-up values (``-p``, ``--params-file``, a node's ``parameter_overrides``) first
(:func:`start_up_values`, through rclpy's public API) and checks each against its spec before
declaring it: an integer literal for a double (``-p drive.k:=4000``) is taken as that
double (4000.0), an empty list (``-p topics:=[]``) as an empty array; any other wrong type
or bad value raises ParamError naming the ROS parameter, which ends the node with exit code
2 (:func:`abb_ros.nodes.ros.entry_point.run_node`). At run time
:func:`coerce_on_set` does the same int -> double conversion before rclpy's type check, and
the nodes' set-parameters callbacks refuse bad values with the ParamError text.
:func:`settings_from` turns the simulator's values into validated (DriveParams, SimSettings).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.exceptions import InvalidParameterValueException
from rclpy.parameter import Parameter

from abb_ros.model.dynamics.spindle import SpindleMotor, TorqueMotor
from abb_ros.model.parameters.param_spec import (
    DOUBLE,
    DOUBLE_ARRAY,
    DRIVE_PREFIX,
    INTEGER,
    ParamSpec,
)
from abb_ros.model.parameters.params import DriveParams, ParamError
from abb_ros.model.parameters.plant_spec import check_rates, imu_config, step_of
from abb_ros.model.sensors.imu import ImuConfig
from abb_ros.nodes.ros.parameter_table import specs_for
from abb_ros.nodes.simulator.hil_settings import HilSettings, hil_settings
from abb_ros.nodes.simulator.params import MIN_REAL_TIME_FACTOR, REAL_TIME_FACTOR_VALID

__all__ = ['DRIVE_PREFIX', 'SIMULATOR_PARAMS', 'SimSettings', 'declare', 'declare_all',
           'coerce_on_set', 'descriptor', 'settings_from', 'current_values', 'validate_change',
           'validate_merged', 'with_ros_names', 'start_up_values', 'P3_WBAR']

P3_WBAR = 2.7
"""Default initial speed: the paper's point P3, wbar = 2.7 (with the drive's omega0)."""

SIMULATOR_PARAMS: dict[str, ParamSpec] = specs_for('simulator')
"""{ROS name: spec} of every simulator parameter, drive.* first."""


def descriptor(spec: ParamSpec) -> ParameterDescriptor:
    """Return the ROS descriptor of ``spec``.

    ROS ranges are closed: an open bound (k > 0) is checked by the spec in the set-parameters
    callback.
    """
    valid = spec.valid_text()
    text = f'{spec.description} [{spec.unit or "-"}]; valid {valid}'
    if spec.applies:
        text += f'; takes effect {spec.applies}'
    d = ParameterDescriptor(description=text, read_only=spec.read_only,
                            additional_constraints=f'valid {valid}')
    if spec.type == INTEGER and spec.low is not None:
        d.integer_range = [IntegerRange(from_value=int(spec.low), to_value=int(spec.high),
                                        step=0)]
    elif spec.type == DOUBLE and spec.low is not None:
        high = math.inf if spec.high is None else float(spec.high)
        d.floating_point_range = [FloatingPointRange(from_value=float(spec.low),
                                                     to_value=high, step=0.0)]
    return d


def declare(node, specs: Mapping[str, ParamSpec], defaults: Mapping[str, Any] = None) -> None:
    """Declare ``specs`` on ``node`` ({ROS name: spec}; ``defaults`` replace spec defaults).

    The start-up overrides are checked first (strict types; an int for a double becomes the
    double); raises ParamError naming the ROS parameter and what is valid.
    """
    defaults = defaults or {}
    overrides = start_up_values(node, specs)
    for name, spec in specs.items():
        value = defaults.get(name, spec.default)
        if name in overrides:
            value = overrides[name]
            if value is None and isinstance(spec.default, list):
                value = []    # rcl reads an empty YAML list ('[]') as no value
            value = spec.check(value, name, strict=True)
        if value == []:
            # rclpy types an empty list as a byte array: declare the type, then set the value
            kind = Parameter.Type[spec.type.upper()]
            node.declare_parameter(name, kind, descriptor(spec), ignore_override=True)
            node.set_parameters([Parameter(name, kind, [])])
        else:
            node.declare_parameter(name, value, descriptor(spec), ignore_override=True)


_NO_OVERRIDE = '\x00abb_ros: no start-up value'
"""The probe's default: what a name without a start-up value is offered as (never stored)."""


def start_up_values(node, names) -> dict[str, Any]:
    """Return the start-up values (``-p``, ``--params-file``, ``parameter_overrides``) by name.

    Read before the parameters are declared, as they were given: an integer for a double, a
    string for a number, None for an empty YAML list. rclpy has no getter for them, but it
    offers them to the on-set-parameters callbacks when a parameter is declared: each name is
    declared once, dynamically typed, with a callback in front of the node's others that
    records the value and refuses it. Refused, nothing is stored and no ``/parameter_events``
    message is published, so the node declares its parameters afterwards as if never probed.
    """
    offered = {}

    def record_and_refuse(parameters):
        offered.update((p.name, p.value) for p in parameters)
        return SetParametersResult(successful=False, reason='start-up value read')

    node.add_on_set_parameters_callback(record_and_refuse)
    try:
        for name in names:
            try:
                node.declare_parameter(name, _NO_OVERRIDE,
                                       ParameterDescriptor(dynamic_typing=True))
            except InvalidParameterValueException:
                pass
            if name not in offered:   # another callback came first and refused
                raise RuntimeError(f'the start-up value of {name} could not be read')
    finally:
        node.remove_on_set_parameters_callback(record_and_refuse)
    return {name: value for name, value in offered.items() if value != _NO_OVERRIDE}


def coerce_on_set(node, specs: Mapping[str, ParamSpec]) -> None:
    """Accept an integer for a double parameter at run time too (``ros2 param set ... 4000``).

    A pre-set callback re-types it as a double before rclpy compares it with the declared
    type. Other wrong types are refused by rclpy's type check.
    """
    int_types = {DOUBLE: Parameter.Type.INTEGER, DOUBLE_ARRAY: Parameter.Type.INTEGER_ARRAY}

    def coerce(parameters):
        out = []
        for p in parameters:
            spec = specs.get(p.name)
            if spec is not None and int_types.get(spec.type) == p.type_:
                value = p.value
                value = float(value) if spec.type == DOUBLE else [float(x) for x in value]
                p = Parameter(p.name, value=value)
            out.append(p)
        return out

    node.add_pre_set_parameters_callback(coerce)


@dataclass(frozen=True)
class SimSettings:
    """The node's own parameters, validated. Rates in Hz, speeds in rad/s."""

    integration_rate_hz: int
    publish_rate_hz: int
    real_time_factor: float
    start_paused: bool
    max_spindle_speed: float
    initial_speed: float
    spindle_max_accel: float
    spindle_tau: float
    seed: int
    imu: ImuConfig
    hil: HilSettings = HilSettings()
    spindle_mode: str = 'speed'
    motor: TorqueMotor = TorqueMotor()
    max_stamp_lag: float = field(kw_only=True)
    """Largest lag of a stamp behind its schedule before a slip [s]."""
    realtime_priority: int = field(kw_only=True)
    """SCHED_FIFO priority of the integrating thread while paced (0: the normal scheduler)."""
    joint_states_throttle_hz: float = field(kw_only=True)
    """Rate of joint_states_throttle [Hz of simulated time]."""

    def spindle(self):
        """Return the Simulation's spindle: the speed loop, or the motor in torque mode."""
        if self.spindle_mode == 'torque':
            return self.motor
        return SpindleMotor(self.spindle_max_accel, self.spindle_tau)

    @property
    def dt_ns(self) -> int:
        """The integration step [ns]."""
        return step_of(self.integration_rate_hz)[0]

    @property
    def dt(self) -> float:
        """The integration step [s]."""
        return step_of(self.integration_rate_hz)[1]

    @property
    def publish_every(self) -> int:
        """Steps between two published states."""
        return self.integration_rate_hz // self.publish_rate_hz

    @property
    def imu_every(self) -> int:
        """Steps between two IMU readings."""
        return self.integration_rate_hz // int(self.imu.rate)


def declare_all(node) -> tuple[DriveParams, SimSettings]:
    """Declare every simulator parameter on ``node`` and return them validated.

    Overrides from --params-file / -p win over the defaults; raises ParamError for invalid
    start-up values.
    """
    drive_specs = {k: s for k, s in SIMULATOR_PARAMS.items() if k.startswith(DRIVE_PREFIX)}
    declare(node, drive_specs)
    drive = with_ros_names(DriveParams.from_mapping)(
        {s.short: node.get_parameter(k).value for k, s in drive_specs.items()})
    declare(node, {k: s for k, s in SIMULATOR_PARAMS.items() if k not in drive_specs},
            {'spindle.initial_speed': P3_WBAR * drive.omega0})
    coerce_on_set(node, SIMULATOR_PARAMS)
    return settings_from(current_values(node))


def current_values(node) -> dict[str, Any]:
    """Return every simulator parameter's current value, by ROS name."""
    return {name: node.get_parameter(name).value for name in SIMULATOR_PARAMS}


def settings_from(values: Mapping[str, Any]) -> tuple[DriveParams, SimSettings]:
    """Return validated parameters from a flat {ROS name: value} mapping; raises ParamError."""
    drive = DriveParams.from_mapping(
        {k[len(DRIVE_PREFIX):]: v for k, v in values.items() if k.startswith(DRIVE_PREFIX)})
    for name, spec in SIMULATOR_PARAMS.items():
        if not name.startswith(DRIVE_PREFIX):
            spec.check(values[name], name)
    check_rates(values)
    factor = values['real_time_factor']
    if 0.0 < factor < MIN_REAL_TIME_FACTOR:
        raise ParamError('real_time_factor', factor, REAL_TIME_FACTOR_VALID,
                         'a publish period would last longer than the pacing clock can wait')
    if values['spindle.initial_speed'] > values['max_spindle_speed']:
        raise ParamError('spindle.initial_speed', values['spindle.initial_speed'],
                         f'[0, max_spindle_speed = {values["max_spindle_speed"]:g}] rad/s')
    settings = SimSettings(
        integration_rate_hz=int(values['integration_rate_hz']),
        publish_rate_hz=int(values['publish_rate_hz']),
        real_time_factor=float(values['real_time_factor']),
        start_paused=bool(values['start_paused']),
        max_spindle_speed=float(values['max_spindle_speed']),
        initial_speed=float(values['spindle.initial_speed']),
        spindle_max_accel=float(values['spindle.max_accel']),
        spindle_tau=float(values['spindle.tau']), seed=int(values['seed']),
        imu=imu_config(values), spindle_mode=str(values['spindle.mode']),
        motor=TorqueMotor.from_values(values), hil=hil_settings(values),
        max_stamp_lag=float(values['max_stamp_lag']),
        realtime_priority=int(values['realtime_priority']),
        joint_states_throttle_hz=float(values['joint_states_throttle_hz']))
    return drive, settings


def with_ros_names(function):
    """Wrap ``function`` so its ParamError names the ROS parameter (drive.k, not k)."""
    def wrapped(*args, **kwargs):
        try:
            return function(*args, **kwargs)
        except ParamError as err:
            if DRIVE_PREFIX + err.name in SIMULATOR_PARAMS:
                raise err.renamed(DRIVE_PREFIX + err.name) from None
            raise
    return wrapped


def validate_merged(values: dict, parameters, build) -> SetParametersResult:
    """Check that ``build`` accepts ``values`` with the proposed ``parameters`` merged in.

    ``values`` is {ROS name: value}; ``build(values)`` raises ParamError for invalid ones.
    No side effects.
    """
    values = dict(values)
    for p in parameters:
        if p.name in values:
            values[p.name] = p.value
    try:
        with_ros_names(build)(values)
    except ParamError as err:
        return SetParametersResult(successful=False, reason=str(err))
    except (TypeError, ValueError) as err:
        return SetParametersResult(successful=False, reason=f'invalid parameter: {err}')
    return SetParametersResult(successful=True)


def validate_change(node, parameters) -> SetParametersResult:
    """Check a proposed change: the on-set-parameters callback body.

    The proposed values merged with the current ones must make valid settings. No side
    effects.
    """
    return validate_merged(current_values(node), parameters, settings_from)
