"""The time-expanded MILP of the path and upload schedule, assembled as numpy/scipy arrays.

Everything is written in terms of a sensor's *worth* w_i(t): its VoI V_i(t) for the VoI
objectives and minus its age, -A_i(t), for the AoI objectives, so that every objective is a
maximisation of a minimum of worths (docs/milp.md has the full formulation).

Variables, created only where they can be 1:

- x[p, t]   binary, the entity stands on point p in slot t (p reachable from start in t moves);
- y[i, s, p] binary, sensor i uploads in slot s at point p (p reachable, in range of i, and the
  upload beats sensor i's initial packet);
- H[i, t, l] in [0, 1], "sensor i's best upload before slot t reaches level l", where the levels
  are the distinct upload scores of sensor i (MODEL.md section 4: an upload's rank never
  changes over time, so "best upload so far" is well defined and replaces "latest upload"
  exactly: a plan never gains from an upload worse than the one it holds);
- z[t] (or a single z), the objective's per-slot minimum worth, in units of ``scale``.

The worth of sensor i in slot t is w0_i(t) + sum_l inc_l(t) H[i, t, l] with telescoping
increments inc_l(t) = w_l(t) - w_(l-1)(t) of the precomputed lookup values w_l(t).

``min-voi`` and ``max-aoi`` are solved by bisection over the finite set of candidate worths with
the pure 0-1 covering models of :func:`build_covering`; the single-z model of :func:`build`
is the same problem as one MILP (used by export and the Pyomo cross-check).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from voiopt import lattice as lattice_mod
from voiopt import physics
from voiopt.errors import OptionError
from voiopt.instance import Instance
from voiopt.simulate import check_objective

# Uploads whose log-scores differ by less than this (relative) are one level (e.g. the four
# lattice points symmetric about a sensor, whose distances differ only by rounding).
SCORE_RTOL = 1e-12

VOI_OBJECTIVES = ("min-voi", "mean-min-voi")
PER_SLOT_OBJECTIVES = ("mean-min-voi", "mean-max-aoi")


def worth_kind(objective: str) -> str:
    """'voi' (worth = V) or 'aoi' (worth = -A)."""
    return "voi" if check_objective(objective) in VOI_OBJECTIVES else "aoi"


# ----------------------------------------------------------------------------- structure


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
    worth0: np.ndarray  # (T+1, N) worth of the initial packet in slot t
    level_worth: list[np.ndarray]  # per sensor (T+1, K_i): w_l(t), nan where not yet reachable
    level_first_slot: list[np.ndarray]  # per sensor (K_i,): earliest slot of an upload at level >= l

    @property
    def n_sensors(self) -> int:
        return self.worth0.shape[1]

    @property
    def n_uploads(self) -> int:
        return len(self.up_col)

    def best_worth(self) -> np.ndarray:
        """(T+1, N): the best worth sensor i can possibly have in slot t (a relaxation)."""
        best = self.worth0.copy()
        for i, w in enumerate(self.level_worth):
            if w.shape[1]:
                top = np.where(np.isnan(w), -np.inf, w).max(axis=1)
                best[:, i] = np.maximum(best[:, i], top)
        return best

    def candidates(self) -> np.ndarray:
        """Sorted distinct worths any sensor can have in any slot t = 1..T."""
        parts = [self.worth0[1:].ravel()]
        for w in self.level_worth:
            v = w[1:].ravel()
            parts.append(v[~np.isnan(v)])
        return np.unique(np.concatenate(parts))


@lru_cache(maxsize=16)
def structure(instance: Instance, kind: str) -> Structure:
    lat = lattice_mod.build(instance)
    T, N, n = instance.horizon, instance.n_sensors, lat.n_points
    ch = instance.channel
    steps = lat.steps_from(lat.start)
    reach = steps[None, :] <= np.arange(T)[:, None]  # (T, n)
    x_col = np.full((T, n), -1, dtype=np.int64)
    x_col[reach] = np.arange(int(reach.sum()))
    n_x = int(reach.sum())

    t_all = np.arange(T + 1)
    rho = np.array([s.rho for s in instance.sensors])
    power = np.array([s.power_w for s in instance.sensors])
    a0 = np.array([s.initial_aoi for s in instance.sensors], dtype=float)
    q0 = np.array([instance.initial_distance(i) for i in range(N)])
    if kind == "voi":
        worth0 = physics.voi(a0[None, :] + t_all[:, None], q0[None, :], rho, power, ch)
        log_c = np.log(physics.distance_factor(power[:, None], lat.distance, ch))  # (N, n)
    else:
        worth0 = -(a0[None, :] + t_all[:, None])
    worth0 = np.asarray(worth0, dtype=float)

    ups: list[tuple[np.ndarray, ...]] = []
    level_worth, level_first = [], []
    for i in range(N):
        s_idx, p_idx = np.nonzero(reach & lat.in_range[i][None, :])
        if kind == "voi":
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
        if kind == "voi":
            ages = t_all[:, None] - s_idx[rep][None, :]
            w = physics.voi(ages, lat.distance[i, p_idx[rep]][None, :], rho[i], power[i], ch)
            w = np.asarray(w, dtype=float).reshape(T + 1, K)
        else:
            w = -(t_all[:, None] - s_idx[rep][None, :]).astype(float)
        w = np.where(t_all[:, None] > first[None, :], w, np.nan)
        # guard the ordering fact against rounding: worth is non-decreasing in the level
        w = np.fmax.accumulate(np.where(np.isnan(w), -np.inf, w), axis=1)
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
    return Structure(
        instance, kind, T, n, x_col, n_x, up_sensor, up_slot, up_point, up_level, up_col,
        worth0, level_worth, level_first,
    )


# ------------------------------------------------------------------------- the model arrays


@dataclass(eq=False)
class Model:
    """One MILP in arrays: maximise cost @ col s.t. row_lower <= A col <= row_upper."""

    structure: Structure
    objective: str
    aggregate: str  # "per-slot" (mean objectives), "single" (min-voi, max-aoi), "covering"
    scale: float  # worth unit of z: worth = scale * z
    col_lower: np.ndarray
    col_upper: np.ndarray
    cost: np.ndarray
    integrality: np.ndarray  # 1 = integer
    row_lower: np.ndarray
    row_upper: np.ndarray
    matrix: sp.csc_matrix
    z_cols: np.ndarray  # columns of z (empty for covering)
    z_row_of: np.ndarray  # (rows,) the z index a row bounds, -1 otherwise
    levels: LevelTerms | None = None
    h_cols: np.ndarray | None = None
    row_blocks: tuple[tuple[str, int], ...] = ()

    @property
    def n_cols(self) -> int:
        return len(self.cost)

    @property
    def n_rows(self) -> int:
        return len(self.row_lower)

    def size(self) -> dict[str, int]:
        return {"rows": self.n_rows, "cols": self.n_cols, "nnz": int(self.matrix.nnz),
                "binaries": int(self.integrality.sum())}

    def col_names(self) -> list[str]:
        """x_t<slot>_p<point>, y_i<sensor>_t<slot>_p<point>, H_i<sensor>_t<slot>_l<level>, z_t<slot>."""
        st = self.structure
        names = [""] * self.n_cols
        for t, p in zip(*np.nonzero(st.x_col >= 0), strict=True):
            names[st.x_col[t, p]] = f"x_t{t}_p{p}"
        for u in range(st.n_uploads):
            names[st.up_col[u]] = f"y_i{st.up_sensor[u]}_t{st.up_slot[u]}_p{st.up_point[u]}"
        if self.levels is not None:
            lt = self.levels
            for e, c in enumerate(self.h_cols):
                names[c] = f"H_i{lt.sensor[e]}_t{lt.slot[e]}_l{lt.level[e]}"
        for k, c in enumerate(self.z_cols):
            names[c] = f"z_t{k + 1}" if len(self.z_cols) > 1 else "z"
        return names

    def row_names(self) -> list[str]:
        counts: dict[str, int] = {}
        names = []
        for prefix, n in self.row_blocks:
            start = counts.get(prefix, 0)
            names += [f"{prefix}{k}" for k in range(start, start + n)]
            counts[prefix] = start + n
        return names

    def to_highs_lp(self, natural_units: bool = False, names: bool = False):
        """A highspy HighsLp. ``natural_units`` states the objective in the objective's own
        units and sense (bit/s maximised, or AoI minimised), as written by :func:`export`."""
        import highspy

        lp = highspy.HighsLp()
        lp.num_col_ = self.n_cols
        lp.num_row_ = self.n_rows
        cost = self.cost.astype(float)
        lp.sense_ = highspy.ObjSense.kMaximize
        if natural_units:
            if self.structure.kind == "voi":
                cost = cost * self.scale
            else:
                cost = -cost * self.scale
                lp.sense_ = highspy.ObjSense.kMinimize
        lp.col_cost_ = cost
        lp.col_lower_ = self.col_lower
        lp.col_upper_ = self.col_upper
        lp.row_lower_ = self.row_lower
        lp.row_upper_ = self.row_upper
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_ = self.matrix.indptr.astype(np.int32)
        lp.a_matrix_.index_ = self.matrix.indices.astype(np.int32)
        lp.a_matrix_.value_ = self.matrix.data.astype(float)
        lp.a_matrix_.num_col_ = self.n_cols
        lp.a_matrix_.num_row_ = self.n_rows
        lp.integrality_ = [
            highspy.HighsVarType.kInteger if v else highspy.HighsVarType.kContinuous
            for v in self.integrality
        ]
        if names:
            lp.col_names_ = self.col_names()
            lp.row_names_ = self.row_names()
        return lp

    # -------------------------------------------------------------- plans and solutions

    def plan_from_solution(self, col_value: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(point indices, schedule with -1) of a solution vector of this model."""
        return plan_from_columns(self.structure, col_value)

    def solution_from_plan(self, idx: np.ndarray, sched: np.ndarray) -> np.ndarray:
        """A full column vector for a plan (its uploads cleaned first): x, y, H and z."""
        st = self.structure
        sched = clean_schedule(st, idx, sched)
        col = np.zeros(self.n_cols)
        col[st.x_col[np.arange(st.horizon), idx]] = 1.0
        for u in upload_ids(st, idx, sched):
            col[st.up_col[u]] = 1.0
        if self.levels is not None:
            best = best_level_before(st, idx, sched)  # (T+1, N)
            lt = self.levels
            col[self.h_cols] = (best[lt.slot, lt.sensor] >= lt.level).astype(float)
        if len(self.z_cols):
            activity = self.matrix @ col  # z columns are still 0
            room = np.full(len(self.z_cols), np.inf)
            rows = np.flatnonzero(self.z_row_of >= 0)
            np.minimum.at(room, self.z_row_of[rows], self.row_upper[rows] - activity[rows])
            col[self.z_cols] = np.clip(room, self.col_lower[self.z_cols], self.col_upper[self.z_cols])
        return col

    def worth_of_objective(self, objective_value: float) -> float:
        """A model objective value (scaled units) as a worth (the mean or the min)."""
        return float(objective_value) * self.scale


def plan_from_columns(st: Structure, col_value: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(point indices, schedule with -1) from the x and y values of a solution; uploads that
    do not beat the sensor's best so far are dropped (they never help, MODEL.md section 4)."""
    xv = np.where(st.x_col >= 0, col_value[np.maximum(st.x_col, 0)], -np.inf)
    idx = xv.argmax(axis=1)
    sched = np.full(st.horizon, -1, dtype=np.int64)
    chosen = (col_value[st.up_col] > 0.5) & (st.up_point == idx[st.up_slot])
    for u in np.flatnonzero(chosen):
        sched[st.up_slot[u]] = st.up_sensor[u]
    return idx, clean_schedule(st, idx, sched)


def upload_ids(st: Structure, idx: np.ndarray, sched: np.ndarray) -> list[int]:
    """The upload (y) index of each scheduled upload; uploads without a y variable (those no
    better than the initial packet) are left out."""
    out = []
    for s in np.flatnonzero(sched >= 0):
        hit = np.flatnonzero((st.up_slot == s) & (st.up_point == idx[s]) & (st.up_sensor == sched[s]))
        if len(hit):
            out.append(int(hit[0]))
    return out


def best_level_before(st: Structure, idx: np.ndarray, sched: np.ndarray) -> np.ndarray:
    """(T+1, N): the highest level any upload of sensor i reached before slot t (-1: none)."""
    T, N = st.horizon, st.n_sensors
    best = np.full((T + 1, N), -1, dtype=np.int64)
    for u in upload_ids(st, idx, sched):
        s, i = st.up_slot[u], st.up_sensor[u]
        best[s + 1:, i] = np.maximum(best[s + 1:, i], st.up_level[u])
    return best


def clean_schedule(st: Structure, idx: np.ndarray, sched: np.ndarray) -> np.ndarray:
    """Drop uploads that do not raise the sensor's best level (or beat the initial packet)."""
    out = np.full(len(sched), -1, dtype=np.int64)
    best = np.full(st.n_sensors, -1, dtype=np.int64)
    for s in np.flatnonzero(sched >= 0):
        i = sched[s]
        hit = np.flatnonzero((st.up_slot == s) & (st.up_point == idx[s]) & (st.up_sensor == i))
        if len(hit) and st.up_level[hit[0]] > best[i]:
            best[i] = st.up_level[hit[0]]
            out[s] = i
    return out


class _Triplets:
    """Row, column, value triplets collected block by block, then one CSC matrix."""

    def __init__(self) -> None:
        self.rows: list[np.ndarray] = []
        self.cols: list[np.ndarray] = []
        self.vals: list[np.ndarray] = []
        self.lower: list[np.ndarray] = []
        self.upper: list[np.ndarray] = []
        self.z_of: list[np.ndarray] = []
        self.blocks: list[tuple[str, int]] = []
        self.n_rows = 0

    def add(self, row_local, col, val, lower, upper, z_of=None, name: str = "r") -> None:
        lower = np.atleast_1d(np.asarray(lower, dtype=float))
        self.blocks.append((name, len(lower)))
        self.rows.append(np.asarray(row_local, dtype=np.int64) + self.n_rows)
        self.cols.append(np.asarray(col, dtype=np.int64))
        self.vals.append(np.broadcast_to(np.asarray(val, dtype=float), np.shape(col)).copy())
        self.lower.append(lower)
        self.upper.append(np.broadcast_to(np.asarray(upper, dtype=float), lower.shape).copy())
        self.z_of.append(np.full(len(lower), -1, dtype=np.int64) if z_of is None else np.asarray(z_of))
        self.n_rows += len(lower)

    def matrix(self, n_cols: int) -> sp.csc_matrix:
        cat = (lambda xs, dt: np.concatenate(xs).astype(dt)) if self.rows else (lambda xs, dt: np.zeros(0, dt))
        m = sp.coo_matrix(
            (cat(self.vals, float), (cat(self.rows, np.int64), cat(self.cols, np.int64))),
            shape=(self.n_rows, n_cols),
        ).tocsc()
        m.sum_duplicates()
        m.sort_indices()
        return m


def _path_rows(st: Structure, tr: _Triplets) -> None:
    """One point per slot; each point entered from itself or a neighbour; TDMA at the point.

    (A flow formulation on the moves has an integral path polytope, but measured on the
    paper's networks it raised the root bound by only 2-3 % and made every solve slower.)"""
    lat = lattice_mod.build(st.instance)
    T = st.horizon
    # sum_p x[p, t] = 1
    t_of, p_of = np.nonzero(st.x_col >= 0)
    tr.add(t_of, st.x_col[t_of, p_of], 1.0, np.ones(T), 1.0, name="one_point")
    # x[p, t] <= sum_{q in N(p) u {p}} x[q, t-1]
    for t in range(1, T):
        pts = np.flatnonzero(st.x_col[t] >= 0)
        nb = lat.neighbors[pts]  # moves are reversible, so predecessors = neighbours
        prev = np.where(nb >= 0, st.x_col[t - 1][np.maximum(nb, 0)], -1)
        r, k = np.nonzero(prev >= 0)
        rows = np.concatenate([np.arange(len(pts)), r])
        cols = np.concatenate([st.x_col[t, pts], prev[r, k]])
        vals = np.concatenate([np.ones(len(pts)), -np.ones(len(r))])
        tr.add(rows, cols, vals, np.full(len(pts), -np.inf), 0.0, name=f"move_t{t}_")
    # sum_i y[i, t, p] <= x[p, t]
    if st.n_uploads:
        key = st.up_slot * st.n_points + st.up_point
        keys, row = np.unique(key, return_inverse=True)
        t_k, p_k = keys // st.n_points, keys % st.n_points
        rows = np.concatenate([row, np.arange(len(keys))])
        cols = np.concatenate([st.up_col, st.x_col[t_k, p_k]])
        vals = np.concatenate([np.ones(st.n_uploads), -np.ones(len(keys))])
        tr.add(rows, cols, vals, np.full(len(keys), -np.inf), 0.0, name="tdma")


def _base_columns(st: Structure) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bounds and integrality of x and y (all binary; x of the start in slot 0 fixed to 1)."""
    n = st.n_x + st.n_uploads
    lower, upper = np.zeros(n), np.ones(n)
    lower[st.x_col[0, lattice_mod.build(st.instance).start]] = 1.0
    integrality = np.zeros(n, dtype=np.int8)
    integrality[: st.n_x + st.n_uploads] = 1
    return lower, upper, integrality


def default_scale(st: Structure, objective: str) -> float:
    """A worth unit that makes the objective O(1): the mean over slots of the best worth the
    weakest sensor could have (an upper bound on mean-min-voi). AoI objectives use 1."""
    if st.kind == "aoi":
        return 1.0
    cap = st.best_worth()[1:].min(axis=1)
    ref = float(cap.mean()) if objective in PER_SLOT_OBJECTIVES else float(cap.min())
    return ref if ref > 0 and math.isfinite(ref) else 1.0


@dataclass(frozen=True, eq=False)
class LevelTerms:
    """The H variables of one objective, grouped by (sensor, level) and by slot within a group,
    with the bounds of z: floor <= z_t <= cap (one entry per z)."""

    sensor: np.ndarray  # (E,) i
    slot: np.ndarray  # (E,) t in 1..T
    level: np.ndarray  # (E,) l
    increment: np.ndarray  # (E,) inc_l(t) >= 0, capped at the z cap, in worth units
    previous: np.ndarray  # (E,) index of the previous H of the same (i, l), -1 for the first
    previous_slot: np.ndarray  # (E,) its slot t', 0 for the first
    cap: np.ndarray  # (n_z,)
    floor: np.ndarray  # (n_z,)
    worth_rows: tuple[np.ndarray, np.ndarray]  # (sensor, slot) pairs that bound z (w0 < cap)

    def uploads(self, st: Structure, e: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (entry, upload u) with u of the entry's sensor, level(u) >= l, slot in [t', t)."""
        es, us = [], []
        for i in range(st.n_sensors):
            ei = np.flatnonzero(self.sensor == i)
            ui = np.flatnonzero(st.up_sensor == i)
            if not len(ei) or not len(ui):
                continue
            hit = (
                (st.up_level[ui][None, :] >= self.level[ei][:, None])
                & (st.up_slot[ui][None, :] >= self.previous_slot[ei][:, None])
                & (st.up_slot[ui][None, :] < self.slot[ei][:, None])
            )
            a, b = np.nonzero(hit)
            es.append(ei[a])
            us.append(ui[b])
        cat = lambda xs: np.concatenate(xs) if xs else np.zeros(0, np.int64)  # noqa: E731
        return cat(es), cat(us)


def level_terms(st: Structure, per_slot: bool) -> LevelTerms:
    """H entries (i, t, l) for live levels l whose lower neighbour is still below the cap on z
    (higher levels cannot raise min_i worth), with telescoping, capped increments."""
    T, N = st.horizon, st.n_sensors
    cap_t = st.best_worth()[1:].min(axis=1)  # z_t <= cap_t
    floor_t = st.worth0[1:].min(axis=1)  # z_t >= floor_t: every sensor keeps at least its packet
    if not per_slot:
        cap_t = np.full(T, cap_t.min())
        floor_t = np.full(T, floor_t.min())
    h_i, h_t, h_l, h_inc = [], [], [], []
    for i in range(N):
        w = st.level_worth[i]
        for t in range(1, T + 1):
            live = ~np.isnan(w[t])
            if not live.any():
                continue
            wl = w[t][live]
            below = np.concatenate([[st.worth0[t, i]], wl[:-1]])
            keep = below < cap_t[t - 1]
            if not keep.any():
                continue
            inc = np.minimum(wl, cap_t[t - 1]) - np.minimum(below, cap_t[t - 1])
            lv = np.flatnonzero(live)[keep]
            h_i.append(np.full(len(lv), i))
            h_t.append(np.full(len(lv), t))
            h_l.append(lv)
            h_inc.append(np.maximum(inc[keep], 0.0))
    cat = lambda xs, dt: np.concatenate(xs).astype(dt) if xs else np.zeros(0, dt)  # noqa: E731
    h_i, h_t, h_l, h_inc = cat(h_i, np.int64), cat(h_t, np.int64), cat(h_l, np.int64), cat(h_inc, float)
    order = np.lexsort((h_t, h_l, h_i))  # grouped by (i, l), by t within a group
    h_i, h_t, h_l, h_inc = h_i[order], h_t[order], h_l[order], h_inc[order]
    same = np.zeros(len(h_i), dtype=bool)
    same[1:] = (h_i[1:] == h_i[:-1]) & (h_l[1:] == h_l[:-1])
    e = np.arange(len(h_i))
    previous = np.where(same, e - 1, -1)
    previous_slot = np.where(same, h_t[np.maximum(e - 1, 0)], 0)
    zi, zt = np.nonzero((st.worth0[1:] < cap_t[:, None]).T)  # (sensor, slot - 1)
    n_z = T if per_slot else 1
    return LevelTerms(h_i, h_t, h_l, h_inc, previous, previous_slot, cap_t[:n_z], floor_t[:n_z], (zi, zt + 1))


def build(instance: Instance, objective: str, *, scale: float | None = None) -> Model:
    """The full MILP for ``objective``: per-slot z for the mean objectives, one z for the
    min/max objectives. Maximises (1/T) sum z_t, or z, in worth units of ``scale``."""
    kind = worth_kind(objective)
    st = structure(instance, kind)
    T = st.horizon
    per_slot = objective in PER_SLOT_OBJECTIVES
    scale = float(scale) if scale is not None else default_scale(st, objective)
    if not (scale > 0 and math.isfinite(scale)):
        raise ValueError(f"scale: must be a positive finite number, got {scale!r}")
    lt = level_terms(st, per_slot)
    h_i, h_t, h_inc = lt.sensor, lt.slot, lt.increment

    lower, upper, base_integrality = _base_columns(st)
    tr = _Triplets()
    _path_rows(st, tr)
    n_base = len(lower)
    h_col = n_base + np.arange(len(h_i))
    n_z = T if per_slot else 1
    z_cols = n_base + len(h_i) + np.arange(n_z)

    # H[i, t, l] - H[i, t', l] - sum_{s in [t', t-1], level(u) >= l} y_u <= 0, t' = the
    # previous slot with an H of the same (i, l), or 0 (and no H term) for the first
    e = np.arange(len(h_i))
    has_prev = lt.previous >= 0
    eu, uu = lt.uploads(st)
    tr.add(
        np.concatenate([e, e[has_prev], eu]),
        np.concatenate([h_col, h_col[lt.previous[has_prev]], st.up_col[uu]]),
        np.concatenate([np.ones(len(e)), -np.ones(int(has_prev.sum())), -np.ones(len(eu))]),
        np.full(len(e), -np.inf),
        0.0,
        name="level",
    )

    # z_t - sum_l inc_l(t)/scale H[i, t, l] <= w0_i(t)/scale for every (i, t) with w0 below the cap
    zi, zt = lt.worth_rows
    row_of = np.full((st.n_sensors, T + 1), -1, dtype=np.int64)
    row_of[zi, zt] = np.arange(len(zt))
    z_index = (zt - 1) if per_slot else np.zeros(len(zt), dtype=np.int64)
    r_h = row_of[h_i, h_t]
    m = r_h >= 0
    tr.add(
        np.concatenate([np.arange(len(zt)), r_h[m]]),
        np.concatenate([z_cols[z_index], h_col[m]]),
        np.concatenate([np.ones(len(zt)), -h_inc[m] / scale]),
        np.full(len(zt), -np.inf),
        st.worth0[zt, zi] / scale,
        z_of=z_index,
        name="worth",
    )

    col_lower = np.concatenate([lower, np.zeros(len(h_i)), lt.floor / scale])
    col_upper = np.concatenate([upper, np.ones(len(h_i)), lt.cap / scale])
    cost = np.zeros(len(col_lower))
    cost[z_cols] = 1.0 / n_z
    integrality = np.zeros(len(col_lower), dtype=np.int8)
    integrality[:n_base] = base_integrality
    model = Model(
        st, objective, "per-slot" if per_slot else "single", scale, col_lower, col_upper, cost,
        integrality, np.concatenate(tr.lower), np.concatenate(tr.upper), tr.matrix(len(col_lower)),
        z_cols, np.concatenate(tr.z_of), lt, h_col, tuple(tr.blocks),
    )
    return model


def build_covering(instance: Instance, objective: str, threshold: float) -> Model | None:
    """The 0-1 feasibility problem "every sensor's worth is >= threshold in every slot"
    (``threshold`` a worth: V for min-voi, -A for max-aoi), or None if some (i, t) cannot
    reach it at all. For each (i, t) whose initial packet is below the threshold: some upload
    of i before t at a level whose worth at t is >= threshold."""
    kind = worth_kind(objective)
    st = structure(instance, kind)
    lower, upper, integrality = _base_columns(st)
    tr = _Triplets()
    _path_rows(st, tr)
    rows, cols, n_cover = [], [], 0
    for i in range(st.n_sensors):
        need = np.flatnonzero(st.worth0[1:, i] < threshold) + 1
        if not len(need):
            continue
        w = st.level_worth[i]
        ui = np.flatnonzero(st.up_sensor == i)
        seen: set[tuple[int, int]] = set()
        for t in need:
            ok = np.flatnonzero(w[t] >= threshold)  # nan compares False
            if not len(ok):
                return None
            l_min = int(ok[0])
            if (t, l_min) in seen:
                continue
            seen.add((t, l_min))
            us = ui[(st.up_level[ui] >= l_min) & (st.up_slot[ui] < t)]
            rows.append(np.full(len(us), n_cover))
            cols.append(st.up_col[us])
            n_cover += 1
    if n_cover:
        tr.add(np.concatenate(rows), np.concatenate(cols), 1.0, np.ones(n_cover), np.inf, name="cover")
    n = len(lower)
    return Model(
        st, objective, "covering", 1.0, lower, upper, np.zeros(n), integrality,
        np.concatenate(tr.lower), np.concatenate(tr.upper), tr.matrix(n), np.zeros(0, np.int64),
        np.concatenate(tr.z_of), row_blocks=tuple(tr.blocks),
    )


# ------------------------------------------------------------------------------------ export

EXPORT_FORMATS = (".mps", ".lp")


def export(instance: Instance, objective: str, path: str | os.PathLike) -> Model:
    """Write the MILP of ``objective`` as MPS or LP (by extension), objective in its own units
    and sense (mean or min VoI in bit/s maximised; mean or max AoI minimised)."""
    check_objective(objective)
    p = Path(path)
    if p.suffix.lower() not in EXPORT_FORMATS:
        raise OptionError(f"model: unknown format {p.suffix or '(none)'!r} of {str(p)!r} (use .mps or .lp)")
    import highspy

    model = build(instance, objective)
    h = highspy.Highs()
    h.silent()
    h.passModel(model.to_highs_lp(natural_units=True, names=True))
    p.parent.mkdir(parents=True, exist_ok=True)
    status = h.writeModel(str(p))
    if status == highspy.HighsStatus.kError:
        raise OptionError(f"model: HiGHS could not write {str(p)!r}")
    return model
