"""One slot of one robot under lossy links (MODEL.md sections 3, 9 and 11), on the observed
state that a policy acts on.

A state is the tuple (point index, moves used, ages A, distances q): the moves used are 0
where ``max_moves`` is not set (they decide nothing then), and q is () for a model that
values AoI only (``voi=False``), whose rewards never read it. An action is (u, m): u a sensor
index or -1 for none, m an index into ``voiopt.grid.lattice.MOVES`` (stay, N, S, E, W); in the
last slot only staying is offered (p(T) is not part of a plan). An upload of u from point p
in slot t succeeds with probability ``succ[t, p, u]``; a failure leaves u as if unscheduled.

``succ`` is a (T, lattice points, N) table (a (points, N) one holds in every slot): the links'
success table (voiopt.core.links.success_table), or a scenario's 0/1 availability.
"""

from __future__ import annotations

import numpy as np

from voiopt.core import physics
from voiopt.core.instance import Instance
from voiopt.core.links import success_table
from voiopt.grid import lattice as lattice_mod

MOVE_NAMES = ("stay", "N", "S", "E", "W")  # the order of voiopt.grid.lattice.MOVES


class Steps:
    """Legal actions, outcomes and rewards of one robot's slots."""

    def __init__(self, instance: Instance, voi: bool, succ: np.ndarray | None = None) -> None:
        self.instance, self.voi_model = instance, voi
        self.lat = lat = lattice_mod.build(instance)
        T, N = instance.horizon, instance.n_sensors
        succ = success_table(instance, lat) if succ is None else np.asarray(succ, dtype=float)
        self.succ = np.broadcast_to(succ, (T, *succ.shape[-2:])) if succ.ndim == 2 else succ
        self.T, self.N = T, N
        self.budgeted = instance.max_moves is not None
        self.rho = [s.rho for s in instance.sensors]
        self.power = [s.power_w for s in instance.sensors]
        self.dist = lat.distance
        self.in_range = [np.flatnonzero(lat.in_range[:, p]).tolist() for p in range(lat.n_points)]
        self._voi: dict = {}
        self._moves: dict = {}  # (t, p, k) -> moves: the lattice's rules, asked once each
        self._uploads: dict = {}  # (t, p) -> uploads

    def start_state(self) -> tuple:
        inst = self.instance
        ages = tuple(s.initial_aoi for s in inst.sensors)
        qs = tuple(inst.initial_distance(i) for i in range(self.N)) if self.voi_model else ()
        return (self.lat.start, 0, ages, qs)

    def voi(self, i: int, age: int, q: float) -> float:
        """V_i at age and effective distance, by physics.voi as the simulator computes it (cached)."""
        key = (i, age, q)
        v = self._voi.get(key)
        if v is None:
            v = self._voi[key] = float(physics.voi(age, q, self.rho[i], self.power[i], self.instance.channel))
        return v

    def reward(self, ages: tuple, qs: tuple) -> float:
        """r of a slot whose sensors stand at ``ages`` and ``qs``: min_i V_i, or -max_i A_i."""
        if not self.voi_model:
            return -float(max(ages))
        return min(self.voi(i, ages[i], qs[i]) for i in range(self.N))

    def moves(self, t: int, p: int, k: int) -> list[tuple[int, int, int]]:
        """The legal (m, next point, next moves used) from p in slot t after k moves."""
        key = (t, p, k)
        hit = self._moves.get(key)
        if hit is None:
            hit = self._moves[key] = self._legal_moves(t, p, k)
        return hit

    def _legal_moves(self, t: int, p: int, k: int) -> list[tuple[int, int, int]]:
        if t == self.T - 1:
            return [(0, p, k)]
        lat, out = self.lat, []
        for m in range(5):
            q = int(lat.neighbors[p, m])
            if q < 0:
                continue
            k2 = k + (m != 0)
            if lat.can_finish(q, t + 1, k2):
                out.append((m, q, k2 if self.budgeted else 0))
        return out

    def uploads(self, t: int, p: int) -> list[tuple[int, float]]:
        """(-1, 0.0) for no upload, then (i, success probability) for each sensor in range
        whose upload can succeed (one that always fails acts as no upload)."""
        hit = self._uploads.get((t, p))
        if hit is not None:
            return hit
        out = self._uploads[(t, p)] = [(-1, 0.0)]
        for i in self.in_range[p]:
            ps = float(self.succ[t, p, i])
            if ps > 0.0:
                out.append((i, ps))
        return out

    def legal(self, t: int, state: tuple, u: int, m: int) -> tuple[int, int] | None:
        """(next point, next moves used) if (u, m) is legal in ``state`` at slot t, else None."""
        p = state[0]
        if u >= 0 and not (0 <= u < self.N and self.lat.in_range[u, p]):
            return None
        return next(((q, k2) for mm, q, k2 in self.moves(t, p, state[1]) if mm == m), None)

    def outcomes(self, t: int, state: tuple, u: int, q: int, k2: int) -> list[tuple[float, tuple]]:
        """(probability, next state) of the action (u, move to q) in ``state`` at slot t; the
        success first, and only the outcomes of probability > 0."""
        p, _, ages, qs = state
        aged = tuple(a + 1 for a in ages)
        fail = (q, k2, aged, qs)
        ps = 0.0 if u < 0 else float(self.succ[t, p, u])
        if ps <= 0.0:
            return [(1.0, fail)]
        won = list(aged)
        won[u] = 1
        if self.voi_model:
            qs = list(qs)
            qs[u] = float(self.dist[u, p])
            qs = tuple(qs)
        win = (q, k2, tuple(won), qs)
        return [(1.0, win)] if ps >= 1.0 else [(ps, win), (1.0 - ps, fail)]

    def succeeded(self, t: int, state: tuple, u: int, uniform: float) -> bool:
        """The outcome of u's upload in a scenario: U(t, u) < p_u(d) (MODEL.md 11)."""
        return u >= 0 and uniform < float(self.succ[t, state[0], u])

    def after(self, t: int, state: tuple, u: int, q: int, k2: int, success: bool) -> tuple:
        """The next state of (u, move to q) with the given outcome."""
        outs = self.outcomes(t, state, u, q, k2)
        if len(outs) == 1:
            return outs[0][1]
        return outs[0][1] if success else outs[1][1]

    def greedy(self, t: int, state: tuple) -> tuple[int, int]:
        """The legal action of the largest expected next reward (first in order on ties): the
        fallback of a policy for an observation its table does not hold."""
        best, arg = -np.inf, (-1, 0)
        for u, _ in self.uploads(t, state[0]):
            for m, q, k2 in self.moves(t, state[0], state[1]):
                r = sum(prob * self.reward(s[2], s[3]) for prob, s in self.outcomes(t, state, u, q, k2))
                if r > best:
                    best, arg = r, (u, m)
        return arg

    def to_objective(self, total: float) -> float:
        """A sum of rewards over the T slots, as the averaged objective's value."""
        mean = total / self.T
        return mean if self.voi_model else -mean
