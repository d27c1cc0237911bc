"""The simulator's run state as the ROS 2 simulation_interfaces standard names it (no rclpy).

One state machine behind ``SetSimulationState``, ``~/pause`` and the stepping services:

- ``PLAYING``: integrating (paced or as fast as possible);
- ``PAUSED``: frozen where it is; ``StepSimulation`` and ``SimulateSteps`` advance it;
- ``STOPPED``: paused and reset to the start (``ResetSimulation`` with ``SCOPE_ALL``), as the
  standard defines it; playing it starts from there, pausing it is refused
  (``INCORRECT_TRANSITION``, the service's own example);
- ``QUITTING``: the node shuts down cleanly (from any state; stopped first, as the standard
  asks).

Values are the standard's (``simulation_interfaces/msg/SimulationState``,
``SetSimulationState``'s result codes) so that this module needs no generated types.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ['STOPPED', 'PLAYING', 'PAUSED', 'QUITTING', 'NO_WORLD', 'LOADING_WORLD',
           'STATE_NAMES', 'Transition', 'RunState']

STOPPED, PLAYING, PAUSED, QUITTING, NO_WORLD, LOADING_WORLD = range(6)
STATE_NAMES = {STOPPED: 'STATE_STOPPED', PLAYING: 'STATE_PLAYING', PAUSED: 'STATE_PAUSED',
               QUITTING: 'STATE_QUITTING', NO_WORLD: 'STATE_NO_WORLD',
               LOADING_WORLD: 'STATE_LOADING_WORLD'}

RESULT_OK = 1
RESULT_INCORRECT_STATE = 3
ALREADY_IN_TARGET_STATE = 101
INCORRECT_TRANSITION = 103


@dataclass(frozen=True)
class Transition:
    """What a request to change the state comes to.

    ``result``: the standard's code (``RESULT_OK`` or a ``SetSimulationState`` code);
    ``message``: why, for ``error_message``; ``reset``: reset to the start first (into
    ``STOPPED``); ``quit``: shut the node down after answering.
    """

    result: int
    message: str = ''
    reset: bool = False
    quit: bool = False

    @property
    def ok(self) -> bool:
        """Whether the state changed."""
        return self.result == RESULT_OK


class RunState:
    """The current state and the transitions the standard allows from it."""

    def __init__(self, paused: bool):
        self.state = PAUSED if paused else PLAYING

    @property
    def paused(self) -> bool:
        """Whether the plant is frozen (PAUSED or STOPPED: nothing integrates)."""
        return self.state != PLAYING

    @property
    def name(self) -> str:
        """The standard's name of the state (STATE_PLAYING, ...)."""
        return STATE_NAMES[self.state]

    def request(self, target: int) -> Transition:
        """Move to ``target`` where the standard allows it; say what that takes."""
        name = STATE_NAMES.get(target)
        if name is None:
            return Transition(INCORRECT_TRANSITION,
                              f'state {target} is not a SimulationState (0..5)')
        if target == self.state:
            return Transition(ALREADY_IN_TARGET_STATE, f'already {name}')
        if target in (NO_WORLD, LOADING_WORLD):
            return Transition(INCORRECT_TRANSITION,
                              f'{name}: this simulator has one world, always loaded')
        if self.state == STOPPED and target == PAUSED:
            return Transition(INCORRECT_TRANSITION,
                              'STATE_STOPPED -> STATE_PAUSED: play it, or step it while stopped')
        transition = Transition(RESULT_OK, reset=target == STOPPED, quit=target == QUITTING)
        self.state = target
        return transition

    def pause(self, paused: bool) -> None:
        """``~/pause`` and the stepping services: paused keeps STOPPED, resuming plays."""
        if paused and self.state == PLAYING:
            self.state = PAUSED
        elif not paused:
            self.state = PLAYING

    def stepped(self) -> None:
        """Record a step: a stopped simulation is merely paused from now on."""
        if self.state == STOPPED:
            self.state = PAUSED
