"""A policy of one robot (MODEL.md section 11): what to do in each slot from what has been
observed, saved as JSON beside its result and loaded again by ``Policy.load``.

The observation (a dict) holds:
- ``slot``: t, 0 .. T-1;
- ``position``: [x, y], the lattice point the robot stands on;
- ``aoi``: [A_0 .. A_{N-1}], every sensor's age of information in slot t;
- ``distance``: [q_0 .. q_{N-1}], every sensor's effective distance (of its last successful
  upload, or its initial_distance);
- ``moves_used``: the slots so far with a change of position; read only where the instance
  sets ``max_moves``.

``act(observation)`` returns an Action: ``sensor`` (an index, or None for no upload) and
``move`` ("stay", "N" (+y), "S", "E" (+x) or "W"); in the last slot the move is "stay" (p(T)
is not part of a plan).

Two kinds:
- ``table``: a table from observation to action (the optimal policy's, Q-learning's greedy
  one). An observation not in the table (one the policy never reaches, or a state Q-learning
  never visited) gets the fallback: the legal action of the largest expected reward in the
  next slot (ties: no upload first, then sensors in index order; moves stay, N, S, E, W).
  Distances are matched to 9 decimals; a table of a ``mean-max-aoi`` policy ignores them.
- ``plan``: an open-loop plan (MODEL.md section 3): slot t's upload and move whatever was
  observed.

The file: ``{"format": "voiopt-policy", "version": 1, "kind", "method", "objective",
"instance": the instance JSON, "fallback": the rule above in words, and "table": rows
[slot, [x, y], moves_used, [A...], [q...] or [], sensor or null, move] or "plan": a plan}``.
"""

from __future__ import annotations

import math
import os
from typing import Any, NamedTuple

from voiopt import objectives
from voiopt.core import instance as instance_mod
from voiopt.core.instance import Instance, show
from voiopt.core.plan import Plan
from voiopt.core.simulate import check_plan
from voiopt.core.steps import MOVE_NAMES, Steps
from voiopt.errors import VoioptError
from voiopt.runtime.files import read_json, reading, write_json_atomic

FORMAT, VERSION = "voiopt-policy", 1
DIGITS = 9  # distances are matched to this many decimals
FALLBACK = ("the legal action of the largest expected reward in the next slot (ties: no upload, then sensors "
            "in index order; moves stay, N, S, E, W)")


class Action(NamedTuple):
    sensor: int | None
    move: str


class Policy:
    """A table from observed state to action, or an open-loop plan, for one robot."""

    def __init__(self, instance: Instance, objective: str, method: str, *, table: dict | None = None,
                 plan: Plan | None = None) -> None:
        objectives.get(objective)
        if (table is None) == (plan is None):
            raise ValueError("a policy is a table or a plan")
        self.instance, self.objective, self.method = instance, objective, method
        self.kind = "table" if table is not None else "plan"
        self.uses_distance = objectives.get(objective).voi
        self.table = table  # (t, point, moves used, ages, rounded distances or ()) -> (u, m)
        self.plan = plan
        self.steps = Steps(instance, voi=True)
        if plan is not None:
            self._idx, self._sched = check_plan(instance, plan)

    def __repr__(self) -> str:
        what = f"a table of {len(self.table)} states" if self.kind == "table" else "an open-loop plan"
        return f"<Policy: {what}, {self.method}, {self.objective}, instance {self.instance.name!r}>"

    # -- acting --------------------------------------------------------------------------------

    def key(self, t: int, state: tuple) -> tuple:
        p, k, ages, qs = state
        return (t, p, k if self.steps.budgeted else 0, tuple(ages),
                tuple(round(q, DIGITS) for q in qs) if self.uses_distance else ())

    def choose(self, t: int, state: tuple) -> tuple[int, int]:
        """(u, m) in a full state (point, moves used, ages, distances) at slot t."""
        if self.kind == "plan":
            return int(self._sched[t]), self._move(t)
        key = self.key(t, state)
        hit = self.table.get(key)
        return hit if hit is not None else self.missing(t, state, key)

    def missing(self, t: int, state: tuple, key: tuple) -> tuple[int, int]:
        """The action of a state the table does not hold: the stated fallback. A policy that
        decides on demand (re-planning, Q-learning's greedy reading) decides here and keeps it."""
        return self.fallback(t, state)

    def fallback(self, t: int, state: tuple) -> tuple[int, int]:
        steps = self.steps
        if not objectives.get(self.objective).voi:
            steps = _aoi_steps(self)
            state = (*state[:3], ())
        return steps.greedy(t, state)

    def act(self, observation: dict) -> Action:
        """The action for an observation (the module's docstring gives its fields)."""
        t, state = self.observed(observation)
        u, m = self.choose(t, state)
        return Action(None if u < 0 else int(u), MOVE_NAMES[m])

    def observed(self, obs: Any) -> tuple[int, tuple]:
        """(slot, state) of an observation dict; VoioptError naming the field if malformed."""
        inst, N = self.instance, self.instance.n_sensors
        if not isinstance(obs, dict):
            raise VoioptError(f"observation: must be a dict, got {show(obs)}")
        try:
            t = obs["slot"]
            if isinstance(t, bool) or not isinstance(t, int) or not 0 <= t < inst.horizon:
                raise VoioptError(f"observation.slot: must be an integer from 0 to {inst.horizon - 1}, got {show(t)}")
            pos = obs["position"]
            p = self.steps.lat.index(float(pos[0]), float(pos[1])) if len(pos) == 2 else None
            if p is None:
                raise VoioptError(f"observation.position: not a lattice point, got {show(pos)}")
            ages, qs = list(obs["aoi"]), list(obs["distance"])
            if len(ages) != N or len(qs) != N:
                raise VoioptError(f"observation: aoi and distance need {N} entries, got {len(ages)} and {len(qs)}")
            for i, a in enumerate(ages):
                if not _whole(a) or a < 1:
                    raise VoioptError(f"observation.aoi[{i}]: must be an integer >= 1, got {show(a)}")
            for i, q in enumerate(qs):
                if isinstance(q, bool) or not isinstance(q, (int, float)) or not 0 <= q < math.inf:
                    raise VoioptError(f"observation.distance[{i}]: must be a finite number >= 0, got {show(q)}")
            ages, qs = tuple(int(a) for a in ages), tuple(float(q) for q in qs)
            k = 0
            if self.steps.budgeted:
                k = obs["moves_used"]
                if not _whole(k) or not 0 <= k <= inst.max_moves:
                    raise VoioptError(f"observation.moves_used: must be an integer from 0 to {inst.max_moves}, "
                                      f"got {show(k)}")
                k = int(k)
        except VoioptError:
            raise
        except KeyError as e:
            raise VoioptError(f"observation: missing field {e}") from None
        except (TypeError, ValueError) as e:
            raise VoioptError(f"observation: malformed ({e})") from None
        return t, (p, k, ages, qs)

    def observation(self, t: int, state: tuple) -> dict[str, Any]:
        """The observation dict of slot t and a state (``observed``'s inverse)."""
        x, y = self.steps.lat.points[state[0]]
        return {"slot": int(t), "position": [float(x), float(y)], "aoi": [int(a) for a in state[2]],
                "distance": [float(q) for q in state[3]], "moves_used": int(state[1])}

    def _move(self, t: int) -> int:
        if t + 1 >= len(self._idx):
            return 0
        return self.steps.lat.move(self._idx[t], self._idx[t + 1])

    # -- files -----------------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"format": FORMAT, "version": VERSION, "kind": self.kind, "method": self.method,
                             "objective": self.objective, "instance": self.instance.to_dict(), "fallback": FALLBACK}
        if self.kind == "plan":
            d["plan"] = self.plan.to_dict()
            return d
        points = self.steps.lat.points
        d["table"] = [[t, [float(points[p, 0]), float(points[p, 1])], k, list(ages), list(qs),
                       None if u < 0 else u, MOVE_NAMES[m]]
                      for (t, p, k, ages, qs), (u, m) in self.table.items()]
        return d

    def save(self, path: str | os.PathLike) -> None:
        """Write the policy's JSON atomically."""
        write_json_atomic(path, self.to_dict())

    @classmethod
    def load(cls, path: str | os.PathLike) -> Policy:
        d = read_json(path, error=VoioptError)
        with reading(path):
            return cls.from_dict(d)

    @classmethod
    def from_dict(cls, d: Any) -> Policy:
        if not isinstance(d, dict) or d.get("format") != FORMAT:
            raise VoioptError(f"format: not a voiopt policy (expected \"format\": \"{FORMAT}\")")
        if d.get("version") != VERSION:
            raise VoioptError(f"version: must be {VERSION}, got {show(d.get('version'))}")
        inst = instance_mod.from_dict(d.get("instance"), "instance")
        kind = d.get("kind")
        if kind == "plan":
            return cls(inst, d.get("objective"), str(d.get("method")), plan=Plan.from_dict(d.get("plan")))
        if kind != "table":
            raise VoioptError(f"kind: must be \"table\" or \"plan\", got {show(kind)}")
        policy = cls(inst, d.get("objective"), str(d.get("method")), table={})
        lat, rows = policy.steps.lat, d.get("table") or []
        # a table that keys on distances (a policy given as a function) keeps them under any objective
        policy.uses_distance = policy.uses_distance or any(isinstance(r, list) and len(r) > 4 and r[4] for r in rows)
        for n, row in enumerate(rows):
            try:
                t, pos, k, ages, qs, u, move = row
                p = lat.index(float(pos[0]), float(pos[1]))
                if p is None or move not in MOVE_NAMES:
                    raise ValueError("position or move")
                key = policy.key(int(t), (p, int(k), tuple(int(a) for a in ages), tuple(float(q) for q in qs)))
                policy.table[key] = (-1 if u is None else int(u), MOVE_NAMES.index(move))
            except (TypeError, ValueError) as e:
                raise VoioptError(f"table[{n}]: malformed row {show(row)} ({e})") from None
        return policy


def _whole(x: Any) -> bool:
    """An integer, or a float with an integer's value (JSON may give 3.0); not a bool."""
    return not isinstance(x, bool) and (isinstance(x, int) or (isinstance(x, float) and x.is_integer()))


def table_of(rows, objective: str, instance: Instance, method: str) -> Policy:
    """A table policy from (slot, state, (u, m)) rows (states as voiopt.core.steps makes them)."""
    policy = Policy(instance, objective, method, table={})
    for t, state, action in rows:
        policy.table[policy.key(t, state)] = action
    return policy


def _aoi_steps(policy: Policy) -> Steps:
    steps = getattr(policy, "_aoi", None)
    if steps is None:
        steps = policy._aoi = Steps(policy.instance, voi=False)
    return steps
