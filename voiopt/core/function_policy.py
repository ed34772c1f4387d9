"""A policy given as a function (MODEL.md section 11): ``act(observation) -> action`` made a
``voiopt.Policy`` table, so that it is valued, compared and saved like voiopt's own policies.

``act`` receives the observation dict of voiopt.core.policy (``slot``, ``position``, ``aoi``,
``distance``, ``moves_used``) and returns ``(sensor, move)``: a sensor index or None for no
upload, and "stay", "N", "S", "E" or "W" (an ``Action`` is such a pair). It is asked once for
each observed state that an evaluation reaches, and its answer is kept in the table (as
re-planning's decisions are, voiopt.solvers.policy.replan), so ``act`` must be deterministic:
a second call on the same state is never made. The table keys on every distance, whatever the
objective (the function may read them). An illegal action (a sensor out of range, a move off
the area, onto a blocked point, with no way left to ``end`` or past ``max_moves``, or other
than "stay" in the last slot) raises OptionError naming the slot, the action and the position.
"""

from __future__ import annotations

import numbers
from collections.abc import Callable
from typing import Any

from voiopt.core.instance import Instance, show
from voiopt.core.policy import Policy
from voiopt.core.steps import MOVE_NAMES
from voiopt.errors import OptionError
from voiopt.runtime.stop import Stop, Stopped

Act = Callable[[dict], Any]


class FunctionPolicy(Policy):
    """A table Policy filled on demand by asking ``act``; ``calls`` counts the questions."""

    def __init__(self, instance: Instance, objective: str, act: Act, method: str = "function",
                 stop: Stop | None = None) -> None:
        if not callable(act):
            raise OptionError(f"act: must be a function of an observation, got {show(act)}")
        if instance.fleet:
            raise OptionError(f"instance: a policy is one robot's; {instance.name} has {instance.n_robots} robots")
        super().__init__(instance, objective, method, table={})
        self.uses_distance = True  # keys hold the distances: the function sees them, whatever the objective reads
        self.function, self.stop = act, stop
        self.calls = 0

    def missing(self, t: int, state: tuple, key: tuple) -> tuple[int, int]:
        if self.stop is not None and self.stop.check() is not None:
            raise Stopped(self.stop.reason)
        observation = self.observation(t, state)
        action = self.function(observation)
        self.calls += 1
        hit = self.table[key] = self.checked(t, state, action)
        return hit

    def checked(self, t: int, state: tuple, action: Any) -> tuple[int, int]:
        """(u, m) of the function's ``action`` in ``state`` at slot t; OptionError if it is
        malformed or illegal there."""
        where = f"at slot {t}, position {self.observation(t, state)['position']}"
        try:
            sensor, move = action
        except (TypeError, ValueError):
            raise OptionError(f"act: must return (sensor or None, move), got {action!r} {where}") from None
        if sensor is not None and (isinstance(sensor, bool) or not isinstance(sensor, numbers.Integral)):
            raise OptionError(f"act: its sensor must be an integer or None, got {sensor!r} {where}")
        if not isinstance(move, str) or move not in MOVE_NAMES:
            raise OptionError(f"act: its move must be one of {', '.join(MOVE_NAMES)}, got {move!r} {where}")
        u, m = -1 if sensor is None else int(sensor), MOVE_NAMES.index(move)
        if self.steps.legal(t, state, u, m) is None:
            legal = [(None if v < 0 else v, MOVE_NAMES[mm]) for v in [-1, *self.steps.in_range[state[0]]]
                     for mm, _, _ in self.steps.moves(t, state[0], state[1])]
            raise OptionError(f"act: action (sensor {u if u >= 0 else None}, move {move!r}) is illegal {where} "
                              f"(legal: {', '.join(f'({v}, {mm})' for v, mm in legal)})")
        return u, m


def policy_from_function(instance: Instance, objective: str, act: Act, method: str = "function") -> FunctionPolicy:
    """A ``voiopt.Policy`` that asks ``act`` (observation -> (sensor or None, move)) for each
    state it meets and keeps the answer: value it with voiopt.core.policy_value, or with
    ``voiopt.evaluate_function`` for a Result."""
    return FunctionPolicy(instance, objective, act, method)
