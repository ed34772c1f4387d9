"""The exact optimal policy of one robot under lossy links (MODEL.md section 11), for the two
averaged objectives, layer by layer over packed states, with compiled kernels.

The same dynamic programme as the plain expectimax (``expectimax.py``), in another order:
- forward, slot by slot, every state of slot t is expanded by every legal action and each of
  its outcomes of probability > 0; the distinct next states, sorted, are slot t+1's layer, so
  each layer holds exactly the states reachable from the start in that slot;
- backward, from the last slot, each state's value is the largest, over the legal actions, of
  the expected worth (reward + value) of its next states, found by binary search in the next
  layer: the same actions in the same order, the same sums in the same order, the same ties
  (the first strictly larger total wins). So its value and its action in every state are
  bit for bit the plain expectimax's (tests/test_policy_layered.py).

A state is one int64 key (``packed.py``): kept are each slot's keys and optimal actions
(9 bytes a state), and the worths of two slots at a time (8 bytes a state); the stop rule
(time, memory counted from those arrays, Ctrl-C) is looked at between runs of a layer, well
within a second of work each. Where the states do not pack into a key, ``exact_search``
returns the plain expectimax instead.
"""

from __future__ import annotations

import numpy as np

from voiopt.core.instance import Instance
from voiopt.core.policy_value import AVERAGED
from voiopt.runtime.stop import Stop, halt_if_asked
from voiopt.solvers.base import warm_up_once
from voiopt.solvers.policy import kernels
from voiopt.solvers.policy.expectimax import Expectimax, averaged_steps
from voiopt.solvers.policy.packed import Packing

CHUNK_CHILDREN = 1 << 22  # next states written by one call of ``expand`` (sorted in about 0.05 s)
CHUNK_STATES = 1 << 18  # states valued by one call of ``backward``


class Layered:
    """The optimal values and actions of every state reachable from the start, layer by layer."""

    def __init__(self, instance: Instance, objective: str, succ: np.ndarray | None = None,
                 stop: Stop | None = None, tick=None) -> None:
        self.steps = averaged_steps(instance, objective, succ)
        self.packing = Packing(self.steps)
        self.stop, self.tick = stop, tick  # tick(states): progress, now and then
        self.T = instance.horizon
        self.states = 0  # the states valued (slots 0 .. T-1), as the plain expectimax counts them
        self.layers: list[np.ndarray] = []  # each slot's keys, sorted (slots 0 .. T)
        self.actions: list[np.ndarray] = []  # each slot's optimal action codes, (u + 1) * 5 + m
        self.tab: dict[str, np.ndarray] = {}

    def solve(self) -> float:
        """The optimal policy's exact expected objective (mean VoI, or mean max AoI)."""
        if not self.packing.fits:
            raise ValueError(f"the layered expectimax cannot pack these states: {self.packing.describe()}")
        tab = self.tab = self.packing.tables(self.stop)
        self.layers = [np.array([self.packing.encode(self.steps.start_state())], dtype=np.int64)]
        self.states = 1
        for t in range(self.T):
            self.layers.append(self.next_layer(t))
            self.states += len(self.layers[-1]) if t + 1 < self.T else 0
        last = self.layers[self.T]
        worth = np.empty(len(last))
        for lo in range(0, len(last), CHUNK_STATES):
            kernels.rewards(last, lo, min(len(last), lo + CHUNK_STATES), self.packing.voi, tab["voi"],
                            tab["a_shift"], tab["a_mask"], tab["q_shift"], tab["q_mask"], worth)
            self.check(worth.nbytes)
        self.actions = [np.empty(0, dtype=np.uint8)] * self.T
        for t in reversed(range(self.T)):
            worth = self.value_layer(t, worth)
        return self.steps.to_objective(float(worth[0]))

    def next_layer(self, t: int) -> np.ndarray:
        """Slot t+1's distinct states, sorted: every outcome of every legal action of slot t's."""
        tab, cur = self.tab, self.layers[t]
        per = max(1, int(tab["mv_n"].max()) * int(tab["up_n"].max()))  # next states of one state, at most
        chunk = max(1, CHUNK_CHILDREN // per)
        buf = np.empty(min(len(cur), chunk) * per, dtype=np.int64)
        tmp = np.empty_like(buf)
        runs: list[np.ndarray] = []  # sorted runs of distinct keys, each under half the one below it
        for lo in range(0, len(cur), chunk):
            n = kernels.expand(cur, lo, min(len(cur), lo + chunk), t, tab["mv_n"], tab["mv_low"], tab["up_n"],
                               tab["up_u"], tab["win_clear"], tab["win_set"], tab["fields"], buf)
            kernels.radix_sort(buf, n, tmp, self.packing.bits)
            runs.append(buf[:kernels.compact(buf, n)].copy())
            self.merge_runs(runs, 2, 2 * buf.nbytes)
        self.merge_runs(runs, 0, 0)
        return runs[0].copy() if runs else np.empty(0, dtype=np.int64)  # a merge's view keeps the repeats' room

    def merge_runs(self, runs: list[np.ndarray], ratio: int, extra: float) -> None:
        """Merge the last two runs while the one below is at most ``ratio`` times the last (0:
        down to one run), looking at the stop rule after each merge."""
        while len(runs) > 1 and (ratio == 0 or len(runs[-2]) <= ratio * len(runs[-1])):
            top = runs.pop()
            runs[-1] = kernels.merge(runs[-1], top)
            self.check(extra + sum(r.nbytes for r in runs))
        self.check(extra + sum(r.nbytes for r in runs))

    def value_layer(self, t: int, nxt_worth: np.ndarray) -> np.ndarray:
        """Slot t's optimal actions (kept) and its states' worths (reward + value; the value
        alone in slot 0), from slot t+1's worths."""
        tab, keys = self.tab, self.layers[t]
        worth = np.empty(len(keys))
        act = np.empty(len(keys), dtype=np.uint8)
        for lo in range(0, len(keys), CHUNK_STATES):
            missing = kernels.backward(keys, lo, min(len(keys), lo + CHUNK_STATES), t, self.layers[t + 1], nxt_worth,
                                       tab["mv_n"], tab["mv_m"], tab["mv_low"], tab["up_n"], tab["up_u"],
                                       tab["up_ps"], tab["win_clear"], tab["win_set"], tab["fields"],
                                       self.packing.voi, tab["voi"], tab["a_shift"], tab["a_mask"], tab["q_shift"],
                                       tab["q_mask"], t > 0, worth, act)
            if missing:
                raise RuntimeError(f"layered expectimax: {missing} next states of slot {t} missing from their layer")
            self.check(nxt_worth.nbytes + worth.nbytes)
        self.actions[t] = act
        return worth

    def on_policy(self) -> list[tuple[int, tuple, tuple[int, int]]]:
        """(slot, state, action) of every state the optimal policy reaches with probability > 0,
        slot by slot, in the plain expectimax's order (its states as first met, success first)."""
        tab, rows = self.tab, []
        layer = self.layers[0]
        for t in range(self.T):
            codes = np.empty(len(layer), dtype=np.uint8)
            out = np.empty(2 * len(layer), dtype=np.int64)
            n = kernels.follow(layer, t, self.layers[t], self.actions[t], tab["mv_n"], tab["mv_m"], tab["mv_low"],
                               tab["up_n"], tab["up_u"], tab["up_ps"], tab["win_clear"], tab["win_set"],
                               tab["fields"], codes, out)
            if n < 0:
                raise RuntimeError(f"layered expectimax: a state of slot {t} on the policy has no action")
            rows += [(t, s, (c // 5 - 1, c % 5)) for s, c in zip(self.packing.decode(layer), codes.tolist(),
                                                                 strict=True)]
            _, first = np.unique(out[:n], return_index=True)
            layer = out[:n][np.sort(first)]
        return rows

    def memory_bytes(self, extra: float = 0.0) -> float:
        """The bytes held: the rules' tables, every slot's keys and actions so far, and ``extra``
        (buffers, worths)."""
        held = sum(a.nbytes for a in self.tab.values()) + sum(k.nbytes for k in self.layers)
        return held + sum(a.nbytes for a in self.actions) + extra

    def check(self, extra: float) -> None:
        """Progress (the states of the slots found so far), then the stop rule:
        voiopt.runtime.stop.Stopped once it says stop."""
        if self.tick is not None:
            self.tick(self.states)
        halt_if_asked(self.stop, self.memory_bytes(extra))


def exact_search(instance: Instance, objective: str, succ: np.ndarray | None = None, stop: Stop | None = None,
                 tick=None) -> Layered | Expectimax:
    """The layered expectimax, or the plain one where the states do not pack into a key."""
    search = Layered(instance, objective, succ, stop, tick)
    return search if search.packing.fits else Expectimax(instance, objective, succ, stop, tick)


def warm_up() -> float:
    """Load (or compile) the kernels once per process on a tiny instance, so that a solve's
    time measures its work alone; the seconds this took (0 once done)."""

    def load():
        from voiopt.core.instance import from_dict
        from voiopt.networks.generate import generate

        tiny = generate(2, 3, width=1.0, height=1.0, seed=0, name="warm-up").to_dict()
        for budget in ({}, {"max_moves": 1}):
            inst = from_dict(tiny | {"links": {"model": "bernoulli", "success": 0.5}} | budget)
            for objective in AVERAGED:
                search = exact_search(inst, objective)
                search.solve()
                search.on_policy()

    return warm_up_once("policy-dp", load)
