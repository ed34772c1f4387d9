"""Candidate uploads ranked by score, and the worth tables of their levels (MODEL.md section 4).

An upload of sensor i in slot s at distance d has score rho_i^(-s) P g0 / (B N0 d^2 + P g0)
(its age in slots for the AoI objectives); which of two uploads is worth more never changes
over time, so "the best upload so far" replaces "the latest upload" exactly. Uploads are
grouped into levels of equal score; w_l(t) is the worth in slot t of a packet at level l.
Used by the MILP and by the Pyomo model.
"""

from __future__ import annotations

import functools
import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from voiopt.core import physics
from voiopt.core.instance import Instance
from voiopt.grid import lattice as lattice_mod
from voiopt.objectives import Worth
from voiopt.runtime.stop import halt_if_asked

# Uploads whose log-scores differ by less than this (relative) are one level (e.g. the four
# lattice points symmetric about a sensor, whose distances differ only by rounding).
SCORE_RTOL = 1e-12


@dataclass(frozen=True, eq=False)
class Structure:
    """Everything about an instance that does not depend on the objective's aggregation.

    Upload arrays are indexed by upload u (one per y variable); level arrays per sensor.
    """

    instance: Instance
    kind: str  # "voi" or "aoi"
    horizon: int
    n_points: int
    x_col: np.ndarray  # (T, n) column of x[p, t], -1 where p is unreachable in slot t
    n_x: int
    up_sensor: np.ndarray  # (M,)
    up_slot: np.ndarray  # (M,)
    up_point: np.ndarray  # (M,)
    up_level: np.ndarray  # (M,) level index of the upload within its sensor
    up_col: np.ndarray  # (M,) column of y (n_x + u)
    stay_slot: np.ndarray  # (S,) slots t >= 1 of the stay variables s[p, t] (only with a binding max_moves)
    stay_point: np.ndarray  # (S,) their points p
    stay_col: np.ndarray  # (S,) their columns, after the y columns
    min_stays: int  # (T - 1) - max_moves: the least number of slots in which the entity stays
    worth0: np.ndarray  # (T+1, N) worth of the initial packet in slot t
    level_worth: list[np.ndarray]  # per sensor (T+1, K_i): w_l(t), nan where not yet reachable
    level_first_slot: list[np.ndarray]  # per sensor (K_i,): earliest slot of an upload at level >= l

    @property
    def n_sensors(self) -> int:
        return self.worth0.shape[1]

    @property
    def n_uploads(self) -> int:
        return len(self.up_col)

    @property
    def n_base(self) -> int:
        """Columns of the path and schedule: x, y and the stay variables."""
        return self.n_x + self.n_uploads + len(self.stay_col)

    def best_worth(self) -> np.ndarray:
        """(T+1, N): the best worth sensor i can possibly have in slot t (a relaxation)."""
        best = self.worth0.copy()
        for i, w in enumerate(self.level_worth):
            if w.shape[1]:
                top = np.where(np.isnan(w), -np.inf, w).max(axis=1)
                best[:, i] = np.maximum(best[:, i], top)
        return best

    def min_worth_cap(self) -> np.ndarray:
        """(T+1,), read-only: ``least_worth_cap``, computed once per Structure (the model's scale,
        its level terms and the bisection's top candidate each ask for it)."""
        return self.least_worth_cap

    @functools.cached_property
    def least_worth_cap(self) -> np.ndarray:
        """(T+1,): an upper bound on min_i worth_i(t), the least worth in slot t, tighter than
        ``best_worth().min(axis=1)``. Each slot uploads at most one sensor per robot, so the
        slots of the N sensors' best uploads so far hold at most K of them each, and one of
        them is at least ceil(N / K) slots old; or a sensor has no upload and holds its initial
        packet. Either way the least worth is at most the best worth any sensor can have from
        an upload that old, or from its initial packet. With rho = 1e-6 a fresh upload is worth
        1e6 times one a slot older: the plain cap let the MILP's coefficients span that range,
        and HiGHS claimed optimal a plan 5e-4 below the optimum (an outside oracle, 2026-12-03)."""
        T = self.horizon
        age = -(-self.n_sensors // self.instance.n_robots)
        before = np.arange(T + 1) - age  # an upload in slot s <= t - age is at least age slots old
        best = self.worth0.max(axis=1)
        for w, first in zip(self.level_worth, self.level_first_slot, strict=True):
            if w.shape[1]:  # level l has an upload of level >= l in slot first[l]; worths rise with l
                old = (first[None, :] <= before[:, None]) & ~np.isnan(w)
                best = np.maximum(best, np.where(old, w, -np.inf).max(axis=1))
        cap = np.minimum(best, self.best_worth().min(axis=1))
        cap.flags.writeable = False  # shared by every caller
        return cap

    def candidates(self, stop=None) -> np.ndarray:
        """Sorted distinct worths any sensor can have in any slot t = 1..T: each sensor's first,
        ``stop`` (voiopt.runtime.stop.Stop) checked between sensors (voiopt.runtime.stop.Stopped), then their
        union. A sensor's levels hold T^2 worths (an AoI worth repeats T times over: one sort of
        all of them took 5.6 s at T = 5342 with 5 sensors)."""
        parts = [np.unique(self.worth0[1:].ravel())]
        for w in self.level_worth:
            halt_if_asked(stop)
            v = w[1:].ravel()
            parts.append(np.unique(v[~np.isnan(v)]))
        every = np.sort(np.concatenate(parts), kind="stable")  # sorted runs, merged
        return every[np.concatenate(([True], every[1:] != every[:-1]))]


_CACHE: OrderedDict = OrderedDict()  # (instance, kind) -> Structure, the 16 most recent
VOI_BLOCK = 1 << 18  # worths computed between two checks of the stop rule (about 0.1 s)


def structure(instance: Instance, kind: str, stop=None) -> Structure:
    """The uploads and worth levels of ``instance`` (kept for the 16 most recent). Its worths
    grow as T^2 (a few hundred ns each: 40 s at T = 2151 with 9 sensors), so ``stop``
    (voiopt.runtime.stop.Stop) is checked every VOI_BLOCK of them: voiopt.runtime.stop.Stopped."""
    key = (instance, kind)
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    st = _structure(instance, kind, stop)
    _CACHE[key] = st
    if len(_CACHE) > 16:
        _CACHE.popitem(last=False)
    return st


def _structure(instance: Instance, kind: str, stop) -> Structure:
    lat = lattice_mod.build(instance)
    T, N, n = instance.horizon, instance.n_sensors, lat.n_points
    ch = instance.channel
    reach = _reach(instance)  # (T, n): on some legal plan of some robot (MODEL.md sections 2, 9, 10)
    x_col = np.full((T, n), -1, dtype=np.int64)
    x_col[reach] = np.arange(int(reach.sum()))
    n_x = int(reach.sum())

    t_all = np.arange(T + 1)
    rho = np.array([s.rho for s in instance.sensors])
    power = np.array([s.power_w for s in instance.sensors])
    a0 = np.array([s.initial_aoi for s in instance.sensors], dtype=float)
    q0 = np.array([instance.initial_distance(i) for i in range(N)])
    if kind == Worth.VOI:
        worth0 = physics.voi(a0[None, :] + t_all[:, None], q0[None, :], rho, power, ch)
        log_c = np.log(physics.distance_factor(power[:, None], lat.distance, ch))  # (N, n)
    else:
        worth0 = -(a0[None, :] + t_all[:, None])
    worth0 = np.asarray(worth0, dtype=float)

    ups: list[tuple[np.ndarray, ...]] = []
    level_worth, level_first = [], []
    for i in range(N):
        halt_if_asked(stop)  # a sensor's levels: T^2 worths (1.2 s at T = 5342 in all; checked between the steps)
        s_idx, p_idx = np.nonzero(reach & lat.in_range[i][None, :])
        if kind == Worth.VOI:
            score = -s_idx * math.log(rho[i]) + log_c[i, p_idx]
            score0 = a0[i] * math.log(rho[i]) + math.log(
                float(physics.distance_factor(power[i], q0[i], ch))
            )
        else:
            score = s_idx.astype(float)
            score0 = -a0[i]
        keep = score > score0 + SCORE_RTOL * max(1.0, abs(score0))
        s_idx, p_idx, score = s_idx[keep], p_idx[keep], score[keep]
        order = np.argsort(score, kind="stable")
        srt = score[order]
        new = np.ones(len(srt), dtype=bool)
        new[1:] = np.diff(srt) > SCORE_RTOL * np.maximum(1.0, np.abs(srt[1:]))
        level_sorted = np.cumsum(new) - 1
        level = np.empty(len(srt), dtype=np.int64)
        level[order] = level_sorted
        K = int(new.sum())
        # the representative of a level is its lowest-scoring member (worth never overstated)
        rep = order[np.flatnonzero(new)]
        min_slot = np.full(K, T, dtype=np.int64)
        np.minimum.at(min_slot, level, s_idx)
        first = np.minimum.accumulate(min_slot[::-1])[::-1]  # earliest slot reaching level >= l
        if kind == Worth.VOI:
            ages = t_all[:, None] - s_idx[rep][None, :]
            w = physics.voi_blocks(ages, lat.distance[i, p_idx[rep]][None, :], rho[i], power[i], ch, axis=1,
                                   block=VOI_BLOCK, stop=stop)
        else:
            w = -(t_all[:, None] - s_idx[rep][None, :]).astype(float)
        halt_if_asked(stop)
        w = np.where(t_all[:, None] > first[None, :], w, np.nan)
        # guard the ordering fact against rounding: worth is non-decreasing in the level
        w = np.fmax.accumulate(np.where(np.isnan(w), -np.inf, w), axis=1)
        halt_if_asked(stop)
        w = np.where(t_all[:, None] > first[None, :], w, np.nan)
        level_worth.append(w)
        level_first.append(first)
        ups.append((np.full(len(s_idx), i), s_idx, p_idx, level))

    up_sensor, up_slot, up_point, up_level = (
        np.concatenate([u[k] for u in ups]).astype(np.int64) for k in range(4)
    )
    order = np.lexsort((up_sensor, up_point, up_slot))  # by slot, then point, then sensor
    up_sensor, up_slot, up_point, up_level = (a[order] for a in (up_sensor, up_slot, up_point, up_level))
    up_col = n_x + np.arange(len(up_sensor))
    min_stays = 0 if instance.fleet else max(0, T - 1 - lat.budget)  # a fleet's budgets: models/milp/fleet.py
    if min_stays:  # s[p, t] for a point in both slots t-1 and t
        stay_slot, stay_point = np.nonzero(reach[1:] & reach[:-1])
        stay_slot = stay_slot + 1
    else:
        stay_slot = stay_point = np.zeros(0, dtype=np.int64)
    stay_col = n_x + len(up_sensor) + np.arange(len(stay_slot))
    return Structure(
        instance, kind, T, n, x_col, n_x, up_sensor, up_slot, up_point, up_level, up_col,
        stay_slot, stay_point, stay_col, min_stays, worth0, level_worth, level_first,
    )


def _reach(instance: Instance) -> np.ndarray:
    """(T, n): the points some robot can stand on in slot t of some legal plan of its own; for
    a fleet the upload (y) columns exist wherever any robot can stand, and which one stands
    there is the fleet model's business."""
    slots = np.arange(instance.horizon)
    reach = lattice_mod.build(instance.robot(0)).on_some_plan(slots)
    for k in range(1, instance.n_robots):
        reach = reach | lattice_mod.build(instance.robot(k)).on_some_plan(slots)
    return reach
