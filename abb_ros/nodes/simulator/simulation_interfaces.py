"""The simulator's ROS 2 simulation_interfaces services and action (docs/ros_api.md).

A thin adapter: requests become calls on the simulator node's run state
(:mod:`abb_ros.runtime.run_state`), its stepping and reset, and the entity kinematics of
:mod:`abb_ros.model.entity_kinematics`; replies carry the standard's result codes. Served
under the node's private names (``~/get_simulator_features``, ...; the standard leaves names
to the simulator). Without the ``simulation_interfaces`` package (the set-up builds it where
cmake and a compiler exist) :func:`serve` logs that once and the node runs without them.
"""

from __future__ import annotations

import math
import time

from abb_ros.model.sensors import entity_kinematics as ek

__all__ = ['serve', 'SERVICES', 'ACTION', 'FEATURES', 'FEEDBACK_PERIOD_S', 'MAX_FILTER_CHARS',
           'MAX_CALL_STEPS', 'MAX_GOAL_STEPS', 'compile_filter']

SERVICES = ('get_simulator_features', 'get_simulation_state', 'set_simulation_state',
            'step_simulation', 'reset_simulation', 'get_entities', 'get_entity_state',
            'get_entities_states', 'set_entity_state')
"""The private service names (``~/name``), one per interface of the same name."""
ACTION = 'simulate_steps'
FEEDBACK_PERIOD_S = 0.1
"""Shortest wall time between two SimulateSteps feedback messages (the last one always goes)."""
BATCH_WALL_S = 0.005
"""Wall time spent stepping a SimulateSteps goal before serving anything else (a cancel too)."""
MAX_CALL_STEPS = 10_000
"""Most steps one StepSimulation call takes: it answers after them, and until then the node
serves nothing else (about a second of wall time at the default rates)."""
MAX_CALL_INTEGRATION_STEPS = 1_000_000
"""... and most integration steps one StepSimulation call takes (fewer steps when a publish
period holds many integration steps)."""
MAX_GOAL_STEPS = 1_000_000_000
"""Most steps one SimulateSteps goal takes (11.6 days of simulated time at 1 kHz); it runs in
batches, and is cancellable, so the node serves everything else meanwhile."""
MAX_FILTER_CHARS = 256
"""Longest ``filters.filter`` taken (entity names are a few characters; a bound keeps the
compile of a filter cheap)."""
FILTER_MAX_MEM = 1 << 20
"""Memory budget of one compiled filter [bytes] (RE2's ``max_mem``): beyond it RE2 refuses."""
FILTER_VALID = (f'a POSIX extended regular expression of at most {MAX_FILTER_CHARS} characters '
                '(RE2 syntax: classes such as [[:alpha:]] and \\d, repetition counts up to '
                '1000; no backreferences or lookaround); empty matches every entity')
"""What ``filters.filter`` may be, as a refusal says it."""
FRAME = 'base'
FRAMES_ACCEPTED = ('', 'base', 'world')
"""Frames a SetEntityState may name: the standard's default (empty: the world) and ours."""


def _feature_names():
    return ('SIMULATION_STATE_GETTING', 'SIMULATION_STATE_SETTING', 'SIMULATION_STATE_PAUSE',
            'STEP_SIMULATION_SINGLE', 'STEP_SIMULATION_MULTIPLE', 'STEP_SIMULATION_ACTION',
            'SIMULATION_RESET', 'SIMULATION_RESET_TIME', 'SIMULATION_RESET_STATE',
            'ENTITY_STATE_GETTING', 'ENTITY_STATE_SETTING')


FEATURES = _feature_names()
"""What GetSimulatorFeatures claims: exactly what is served here (no spawning, deleting,
named poses, bounds, tags, categories, entity info, worlds, SCOPE_SPAWNED)."""


def serve(node):
    """Create the services and the action on ``node``; return the server or None.

    None (logged once) when the generated ``simulation_interfaces`` package is missing.
    """
    try:
        import simulation_interfaces.action  # noqa: F401
        import simulation_interfaces.msg  # noqa: F401
        import simulation_interfaces.srv  # noqa: F401
    except ImportError:
        node.get_logger().info(
            'simulation_interfaces is not installed: running without its services '
            '(scripts/ensure-venv builds it where cmake and a C/C++ compiler exist; after a '
            'first scripts/run, a background set-up builds it, see .venv/setup-background.log, '
            'and the next start has them)')
        return None
    return SimulationInterfacesServer(node)


class SimulationInterfacesServer:
    """The services and the action on one simulator node (see the module docstring)."""

    def __init__(self, node):
        from rclpy.action import ActionServer, CancelResponse, GoalResponse
        from simulation_interfaces import srv
        from simulation_interfaces.action import SimulateSteps
        from simulation_interfaces.msg import Result, SimulatorFeatures

        self.node = node
        self.Result = Result
        self.features = [getattr(SimulatorFeatures, name) for name in FEATURES]
        self._job = None
        handlers = {'get_simulator_features': (srv.GetSimulatorFeatures, self._features),
                    'get_simulation_state': (srv.GetSimulationState, self._get_state),
                    'set_simulation_state': (srv.SetSimulationState, self._set_state),
                    'step_simulation': (srv.StepSimulation, self._step),
                    'reset_simulation': (srv.ResetSimulation, self._reset),
                    'get_entities': (srv.GetEntities, self._get_entities),
                    'get_entity_state': (srv.GetEntityState, self._get_entity_state),
                    'get_entities_states': (srv.GetEntitiesStates, self._get_entities_states),
                    'set_entity_state': (srv.SetEntityState, self._set_entity_state)}
        self.services = [node.create_service(kind, f'~/{name}', callback)
                         for name, (kind, callback) in handlers.items()]
        self.action = ActionServer(
            node, SimulateSteps, f'~/{ACTION}', execute_callback=self._execute,
            goal_callback=lambda _goal: GoalResponse.ACCEPT,
            cancel_callback=lambda _goal_handle: CancelResponse.ACCEPT)

    def destroy(self) -> None:
        """Destroy the action server (its goal handles go with it)."""
        self.action.destroy()

    def _result(self, code: int, message: str = ''):
        return self.Result(result=code, error_message=message)

    def _ok(self):
        return self._result(self.Result.RESULT_OK)

    # ---- features and state -------------------------------------------------------------------
    def _features(self, _request, response):
        response.features.features = self.features
        response.features.custom_info = (
            'abb_ros drive simulator: one step = one publish period (publish_rate_hz); '
            'entities deck, rotor, ball_1..ball_n in frame base; docs/ros_api.md')
        return response

    def _get_state(self, _request, response):
        response.state.state = self.node.run_state.state
        response.result = self._ok()
        return response

    def _set_state(self, request, response):
        outcome = self.node.set_run_state(request.state.state)
        response.result = self._result(outcome.result, outcome.message)
        return response

    # ---- stepping ---------------------------------------------------------------------------
    def _refuse_step(self):
        """Return a Result refusing to step now, or None when stepping is possible."""
        if self._job is not None:
            return self._result(self.Result.RESULT_INCORRECT_STATE, self.goal_owns_stepping())
        if not self.node.run_state.paused:
            return self._result(self.Result.RESULT_INCORRECT_STATE,
                                'the simulation is playing: pause it first '
                                '(SetSimulationState STATE_PAUSED)')
        if self.node.fault:
            return self._result(self.Result.RESULT_OPERATION_FAILED,
                                f'{self.node.fault}; reset the simulation')
        return None

    def goal_owns_stepping(self) -> str:
        """Why nothing else may step, play, stop or reset now ('' when no goal is stepping)."""
        job = self._job
        if job is None:
            return ''
        return (f'a SimulateSteps goal owns the stepping ({job.done} of {job.steps} steps '
                'done): cancel it or wait for its result')

    def call_step_limit(self) -> int:
        """Most steps a StepSimulation call takes at the present rates (at least 1)."""
        every = max(1, int(self.node.sampler.publish_every))
        return max(1, min(MAX_CALL_STEPS, MAX_CALL_INTEGRATION_STEPS // every))

    def _step(self, request, response):
        limit = self.call_step_limit()
        if request.steps > limit:
            response.result = self._result(
                self.Result.RESULT_OPERATION_FAILED,
                f'steps {request.steps}: at most {limit} per StepSimulation call at these rates '
                f'({MAX_CALL_STEPS} publish periods and {MAX_CALL_INTEGRATION_STEPS} '
                'integration steps; the call holds the node until it answers); more steps: '
                f'the SimulateSteps action ~/{ACTION} (in batches, cancellable, at most '
                f'{MAX_GOAL_STEPS} per goal)')
            return response
        refusal = self._refuse_step()
        if refusal is not None:
            response.result = refusal
            return response
        done = self.node.step_periods(request.steps)
        response.result = (self._ok() if done == request.steps else self._result(
            self.Result.RESULT_OPERATION_FAILED,
            f'{self.node.fault or "the node is stopping"} after {done} of {request.steps} '
            'steps'))
        return response

    async def _execute(self, goal_handle):
        """Step a goal in batches of BATCH_WALL_S from a timer, answering cancels between."""
        from rclpy.task import Future
        from simulation_interfaces.action import SimulateSteps

        result = SimulateSteps.Result()
        with self.node.plant_lock:   # rclpy runs actions outside the node's wrapped callbacks
            refusal = self._refuse_step()
        if goal_handle.request.steps > MAX_GOAL_STEPS:
            refusal = self._result(
                self.Result.RESULT_OPERATION_FAILED,
                f'steps {goal_handle.request.steps}: at most {MAX_GOAL_STEPS} per SimulateSteps '
                'goal; send another goal after this one for more')
        if refusal is not None:
            result.result = refusal
            goal_handle.abort()
            return result
        job = _StepJob(goal_handle, goal_handle.request.steps, Future())
        self._job = job
        timer = self.node.create_timer(0.0, lambda: self._step_batch(job),
                                       clock=self.node.steady_clock)
        try:
            await job.finished
        finally:
            self.node.destroy_timer(timer)
            self._job = None
        self._feedback(job)
        if job.cancelled:
            result.result = self._result(self.Result.RESULT_OK,
                                         f'cancelled after {job.done} of {job.steps} steps')
            goal_handle.canceled()
        elif job.done < job.steps:
            result.result = self._result(
                self.Result.RESULT_OPERATION_FAILED,
                f'{self.node.fault or "the node is stopping"} after {job.done} steps')
            goal_handle.abort()
        else:
            result.result = self._ok()
            goal_handle.succeed()
        return result

    def _step_batch(self, job) -> None:
        if job.finished.done():
            return
        if job.goal_handle.is_cancel_requested:
            job.cancelled = True
            job.finished.set_result(True)
            return
        end = time.perf_counter() + BATCH_WALL_S
        while job.done < job.steps and time.perf_counter() < end:
            if self.node.step_periods(1) != 1:
                job.finished.set_result(True)
                return
            job.done += 1
        if job.done >= job.steps:
            job.finished.set_result(True)
        elif time.monotonic() - job.fed_at >= FEEDBACK_PERIOD_S:
            self._feedback(job)

    def _feedback(self, job) -> None:
        from simulation_interfaces.action import SimulateSteps
        job.fed_at = time.monotonic()
        job.goal_handle.publish_feedback(SimulateSteps.Feedback(
            completed_steps=job.done, remaining_steps=job.steps - job.done))

    # ---- reset --------------------------------------------------------------------------------
    def _reset(self, request, response):
        from simulation_interfaces.srv import ResetSimulation as R
        scope = request.scope
        if scope in (R.Request.SCOPE_DEFAULT, R.Request.SCOPE_ALL):
            time_, state = True, True
        elif scope & ~(R.Request.SCOPE_TIME | R.Request.SCOPE_STATE):
            response.result = self._result(
                self.Result.RESULT_FEATURE_UNSUPPORTED,
                f'scope {scope}: only SCOPE_TIME (1), SCOPE_STATE (2), their sum, SCOPE_ALL '
                'and SCOPE_DEFAULT; nothing is ever spawned here (no SCOPE_SPAWNED)')
            return response
        else:
            time_, state = bool(scope & R.Request.SCOPE_TIME), bool(scope & R.Request.SCOPE_STATE)
        if self._job is not None:
            response.result = self._result(self.Result.RESULT_INCORRECT_STATE,
                                           self.goal_owns_stepping())
            return response
        self.node.reset_simulation(time=time_, state=state)
        response.result = self._ok()
        return response

    # ---- entities -------------------------------------------------------------------------------
    def _matching(self, filters):
        """(names matching ``filters``, None) or (None, a refusing Result)."""
        from simulation_interfaces.msg import Bounds
        if filters.categories:
            return None, self._result(self.Result.RESULT_FEATURE_UNSUPPORTED,
                                      'entity categories are not supported')
        if filters.tags.tags:
            return None, self._result(self.Result.RESULT_FEATURE_UNSUPPORTED,
                                      'entity tags are not supported')
        pattern, why = compile_filter(filters.filter)
        if why:
            return None, self._result(self.Result.RESULT_OPERATION_FAILED, why)
        names = ek.entity_names(self.node.drive.n_balls)
        if pattern is not None:
            names = [n for n in names if pattern.search(n)]
        bounds = filters.bounds
        if bounds.type == Bounds.TYPE_EMPTY:
            return names, None
        if bounds.type != Bounds.TYPE_SPHERE or len(bounds.points) != 2:
            return None, self._result(self.Result.RESULT_FEATURE_UNSUPPORTED,
                                      'only TYPE_SPHERE bounds (2 points) filter entities')
        c, r = bounds.points[0], bounds.points[1].x
        states = self.node.entity_kinematics()
        return [n for n in names if math.dist(states[n].position, (c.x, c.y, c.z)) <= r], None

    def _get_entities(self, request, response):
        names, refusal = self._matching(request.filters)
        response.result = refusal or self._ok()
        response.entities = names or []
        return response

    def _get_entities_states(self, request, response):
        names, refusal = self._matching(request.filters)
        response.result = refusal or self._ok()
        if names:
            states, stamp = self.node.entity_kinematics(), self.node.stamp_ns()
            response.entities = names
            response.states = [self._entity_state(states[n], stamp) for n in names]
        return response

    def _get_entity_state(self, request, response):
        states = self.node.entity_kinematics()
        if request.entity not in states:
            response.result = self._not_found(request.entity)
            return response
        response.state = self._entity_state(states[request.entity], self.node.stamp_ns())
        response.result = self._ok()
        return response

    def _not_found(self, name: str):
        return self._result(self.Result.RESULT_NOT_FOUND,
                            f'no entity {name!r}: entities are '
                            + ', '.join(ek.entity_names(self.node.drive.n_balls)))

    def _entity_state(self, k: ek.Kinematics, stamp_ns: int):
        from simulation_interfaces.msg import EntityState
        msg = EntityState()
        msg.header.frame_id = FRAME
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp_ns), 1_000_000_000)
        p, o = msg.pose.position, msg.pose.orientation
        p.x, p.y, p.z = k.position
        o.x, o.y, o.z, o.w = k.orientation
        _put(msg.twist.linear, k.linear_velocity)
        _put(msg.twist.angular, k.angular_velocity)
        _put(msg.acceleration.linear, k.linear_acceleration)
        _put(msg.acceleration.angular, k.angular_acceleration)
        return msg

    def _set_entity_state(self, request, response):
        from simulation_interfaces.srv import SetEntityState
        name, state = request.entity, request.state
        names = ek.entity_names(self.node.drive.n_balls)
        if name not in names:
            response.result = self._not_found(name)
            return response
        if state.header.frame_id not in FRAMES_ACCEPTED:
            response.result = self._result(
                self.Result.RESULT_OPERATION_FAILED,
                f'frame {state.header.frame_id!r}: states are set in the world frame '
                f"('' or {FRAME!r})")
            return response
        if name == ek.ROTOR:
            response.result = self._result(
                self.Result.RESULT_OPERATION_FAILED,
                'the rotor turns with the spindle: command its speed on spindle/speed_cmd '
                '(its angle and speed are not free coordinates)')
            return response
        bad = [field for field, v in _fields(state) if not math.isfinite(v)]
        if bad:
            response.result = self._result(SetEntityState.Response.INVALID_POSE,
                                           f'{name}: {", ".join(bad)} not finite; valid: '
                                           'finite numbers')
            return response
        try:
            self.node.set_entity(name, state)
        except ek.EntityError as err:
            why = str(err)
            response.result = self._result(SetEntityState.Response.INVALID_POSE,
                                           why if why.startswith(name) else f'{name}: {why}')
            return response
        response.result = self._ok()
        return response


def compile_filter(pattern: str):
    """Compile a ``filters.filter``: (the expression or None for empty, '') or (None, why).

    RE2 (the ``google-re2`` wheel), a linear-time engine: no pattern can make a match
    backtrack, and its parser refuses, with a message, what kills or freezes Python's ``re``
    (huge repetition counts, deep nesting). The pattern is bounded to MAX_FILTER_CHARS and its
    program to FILTER_MAX_MEM. ``why`` names the field and says what is valid.
    """
    if not pattern:
        return None, ''
    shown = repr(pattern if len(pattern) <= 60 else pattern[:60] + '...')
    if len(pattern) > MAX_FILTER_CHARS:
        return None, (f'filters.filter {shown}: {len(pattern)} characters; valid: '
                      + FILTER_VALID)
    try:
        import re2
    except ImportError:
        return None, ('filters.filter: the google-re2 package is not installed (requirements.'
                      'txt): only an empty filter is served')
    options = re2.Options()
    options.log_errors = False   # the reason goes into the reply, not onto stderr
    options.max_mem = FILTER_MAX_MEM
    try:
        return re2.compile(pattern, options), ''
    except (re2.error, ValueError, TypeError) as err:   # UnicodeError is a ValueError
        reason = err.args[0] if err.args else type(err).__name__
        if isinstance(reason, bytes):
            reason = reason.decode('utf-8', 'replace')
        return None, f'filters.filter {shown}: {reason}; valid: {FILTER_VALID}'


class _StepJob:
    """A SimulateSteps goal being stepped."""

    def __init__(self, goal_handle, steps: int, finished):
        self.goal_handle = goal_handle
        self.steps = int(steps)
        self.finished = finished
        self.done = 0
        self.cancelled = False
        self.fed_at = time.monotonic()


def _put(vector, values) -> None:
    vector.x, vector.y, vector.z = values


def _fields(state) -> list[tuple[str, float]]:
    """(field name, value) of each number of an EntityState's pose and twist."""
    out = []
    for field, vector, axes in (('pose.position', state.pose.position, 'xyz'),
                                ('pose.orientation', state.pose.orientation, 'xyzw'),
                                ('twist.linear', state.twist.linear, 'xyz'),
                                ('twist.angular', state.twist.angular, 'xyz')):
        out += [(f'state.{field}.{axis}', getattr(vector, axis)) for axis in axes]
    return out


def state_vectors(state):
    """(position, orientation xyzw, velocity, angular velocity) of an EntityState."""
    p, o, t = state.pose.position, state.pose.orientation, state.twist
    return ((p.x, p.y, p.z), (o.x, o.y, o.z, o.w), (t.linear.x, t.linear.y, t.linear.z),
            (t.angular.x, t.angular.y, t.angular.z))


