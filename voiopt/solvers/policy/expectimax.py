"""The exact optimal policy of one robot under lossy links (MODEL.md section 11), for the two
averaged objectives: finite-horizon dynamic programming (expectimax) over the states reachable
from the start.

A state (voiopt.core.steps) is the position, the moves used where ``max_moves`` is set, and
every sensor's A and q (q dropped for ``mean-max-aoi``, whose reward does not read it). Its
value in slot t is the largest expected sum of the rewards r(t+1) .. r(T) still to come,
r = min_i V_i or -max_i A_i, over the legal actions and each upload's two outcomes. States
are memoised per slot (a dict of state tuples), so each reachable state is valued once; ties
go to the first action in the order: no upload, sensors 0..N-1; moves stay, N, S, E, W.

With a 0/1 success table (a scenario's availability) the programme is deterministic: the
lossless problem of that scenario, and its value that problem's exact optimum.

This is the plain programme: the reference that the layered, compiled one (``layered.py``,
which policy-dp and the information relaxation run) equals bit for bit, and the fallback where
a state does not pack into one key.
"""

from __future__ import annotations

import sys

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.core.policy_value import AVERAGED
from voiopt.core.steps import Steps
from voiopt.runtime.stop import Stop, Stopped

CHECK_EVERY = 4096  # new states between two looks at the stop rule
STATE_BYTES = 360  # a memoised state: two dict entries, key tuples, value pair and worth, about (N = 3)


def averaged_steps(instance: Instance, objective: str, succ: np.ndarray | None) -> Steps:
    """The slots' rules for an averaged objective (ValueError for another): what both searches
    (this one and ``layered.py``'s) start from."""
    if objective not in AVERAGED:
        raise ValueError(f"objective {objective!r}: the expectimax takes only {', '.join(AVERAGED)}")
    return Steps(instance, objectives.get(objective).voi, succ)


class Expectimax:
    """The optimal values and actions of every state reachable from the start."""

    def __init__(self, instance: Instance, objective: str, succ: np.ndarray | None = None,
                 stop: Stop | None = None, tick=None) -> None:
        self.steps = averaged_steps(instance, objective, succ)
        self.objective, self.stop, self.tick = objective, stop, tick  # tick(states): progress, now and then
        self.T = instance.horizon
        self.memo: list[dict] = [{} for _ in range(self.T + 1)]
        self.worths: list[dict] = [{} for _ in range(self.T + 1)]
        self.states = 0
        recursion_room(self.T)

    def value(self, t: int, state: tuple) -> float:
        """The largest expected sum of r(t+1) .. r(T) from ``state`` in slot t (memoised)."""
        if t == self.T:
            return 0.0
        memo = self.memo[t]
        hit = memo.get(state)
        if hit is not None:
            return hit[0]
        self._count()
        steps = self.steps
        best, best_action = -np.inf, None
        for u, _ in steps.uploads(t, state[0]):
            for m, q, k2 in steps.moves(t, state[0], state[1]):
                total = 0.0
                for prob, nxt in steps.outcomes(t, state, u, q, k2):
                    total += prob * self.worth(t + 1, nxt)
                if total > best:
                    best, best_action = total, (u, m)
        memo[state] = (best, best_action)
        return best

    def worth(self, t: int, state: tuple) -> float:
        """r(t) of ``state`` plus its value: what reaching it in slot t is worth (memoised)."""
        memo = self.worths[t]
        w = memo.get(state)
        if w is None:
            w = memo[state] = self.steps.reward(state[2], state[3]) + self.value(t, state)
        return w

    def action(self, t: int, state: tuple) -> tuple[int, int]:
        """The optimal (u, m) in ``state`` at slot t."""
        self.value(t, state)
        return self.memo[t][state][1]

    def solve(self) -> float:
        """The optimal policy's exact expected objective (mean VoI, or mean max AoI)."""
        return self.steps.to_objective(self.value(0, self.steps.start_state()))

    def on_policy(self) -> list[tuple[int, tuple, tuple[int, int]]]:
        """(slot, state, action) of every state the optimal policy reaches with probability > 0,
        slot by slot, in a deterministic order."""
        steps = self.steps
        out, layer = [], [steps.start_state()]
        for t in range(self.T):
            nxt: dict = {}
            for s in layer:
                u, m = self.action(t, s)
                out.append((t, s, (u, m)))
                q, k2 = steps.legal(t, s, u, m)
                for _, s2 in steps.outcomes(t, s, u, q, k2):
                    nxt.setdefault(s2, None)
            layer = list(nxt)
        return out

    def _count(self) -> None:
        self.states += 1
        if self.states % CHECK_EVERY == 0:
            if self.tick is not None:
                self.tick(self.states)
            if self.stop is not None and self.stop.check(self.memory_bytes()) is not None:
                raise Stopped(self.stop.reason)

    def memory_bytes(self) -> float:
        return self.states * (STATE_BYTES + 16 * self.steps.N)


def recursion_room(horizon: int) -> None:
    """The programme recurses once per slot (a few frames each): room for long horizons."""
    need = 8 * horizon + 200
    if sys.getrecursionlimit() < need:
        sys.setrecursionlimit(need)
