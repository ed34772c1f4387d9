"""One MILP in arrays (a whole CSC matrix, passed to HiGHS in one passModel call), with its
column and row names and the map from a plan to a full column vector."""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from voiopt.runtime.stop import halt_if_asked
from voiopt.solvers.milp import fleet as fleet_mod
from voiopt.solvers.milp.solution import (
    best_level_of,
    clean_schedule,
    plan_from_columns,
    upload_ids,
)
from voiopt.solvers.milp.uploads import Structure

PAIR_BLOCK = 1 << 22  # entry-upload cells tested at once by LevelTerms.uploads (4 MB of booleans)


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

    def uploads(self, st: Structure, stop=None) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (entry, upload u) with u of the entry's sensor, level(u) >= l, slot in [t', t).

        Tested a block of entries at a time, at most PAIR_BLOCK entry-upload cells each: a
        sensor's entries times its uploads grow as T^2 (80 GiB at T = 2680 in one piece, a
        fuzz campaign found). ``stop`` (voiopt.runtime.stop.Stop) is checked between blocks, with the
        pairs so far as the memory used: voiopt.runtime.stop.Stopped."""
        es, us, held, blocks = [], [], 0, 0
        for i in range(st.n_sensors):
            ei = np.flatnonzero(self.sensor == i)
            ui = np.flatnonzero(st.up_sensor == i)
            if not len(ei) or not len(ui):
                continue
            level, slot = st.up_level[ui][None, :], st.up_slot[ui][None, :]
            rows = max(1, PAIR_BLOCK // len(ui))
            for start in range(0, len(ei), rows):
                blocks += 1
                if blocks > 1:
                    halt_if_asked(stop, memory_used=16.0 * held)
                eb = ei[start:start + rows]
                hit = ((level >= self.level[eb][:, None]) & (slot >= self.previous_slot[eb][:, None])
                       & (slot < self.slot[eb][:, None]))
                a, b = np.nonzero(hit)
                es.append(eb[a])
                us.append(ui[b])
                held += len(a)
        cat = lambda xs: np.concatenate(xs) if xs else np.zeros(0, np.int64)  # noqa: E731
        return cat(es), cat(us)


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
    fleet: fleet_mod.FleetColumns | None = None  # several robots (models/milp/fleet.py), else None

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
        """x_t<slot>_p<point>, y_i<sensor>_t<slot>_p<point>, s_t<slot>_p<point> (stays, with a
        budget), H_i<sensor>_t<slot>_l<level>, z_t<slot>; a fleet's columns are named by
        FleetColumns.name."""
        st = self.structure
        names = [""] * self.n_cols
        for name, c in path_names(st).items():
            names[c] = name
        for c, t, p in zip(st.stay_col, st.stay_slot, st.stay_point, strict=True):
            names[c] = f"s_t{t}_p{p}"
        if self.levels is not None:
            lt = self.levels
            for e, c in enumerate(self.h_cols):
                names[c] = f"H_i{lt.sensor[e]}_t{lt.slot[e]}_l{lt.level[e]}"
        for k, c in enumerate(self.z_cols):
            names[c] = worth_name(k, len(self.z_cols))
        if self.fleet is not None:
            self.fleet.name(names, st)
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
        """(point indices, schedule with -1) of a solution vector of this model: (T,) arrays,
        or (K, T) for a fleet."""
        if self.fleet is not None:
            return fleet_mod.plan_from_columns(self.structure, self.fleet, col_value)
        return plan_from_columns(self.structure, col_value)

    def solution_from_plan(self, idx: np.ndarray, sched: np.ndarray) -> np.ndarray:
        """A full column vector for a plan (its uploads cleaned first): x, y, H and z."""
        st = self.structure
        if self.fleet is not None:
            col, best = fleet_mod.path_columns(st, self.fleet, self.n_cols, idx, sched)
        else:
            sched = clean_schedule(st, idx, sched)
            col = np.zeros(self.n_cols)
            col[st.x_col[np.arange(st.horizon), idx]] = 1.0
            stays = idx[st.stay_slot] == idx[st.stay_slot - 1]
            col[st.stay_col[stays & (idx[st.stay_slot] == st.stay_point)]] = 1.0
            ids = upload_ids(st, idx, sched)
            for u in ids:
                col[st.up_col[u]] = 1.0
            best = best_level_of(st, ids)  # (T+1, N)
        if self.levels is not None:
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


class Triplets:
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


def path_names(st: Structure) -> dict[str, int]:
    """The column of every x and y name, x_t<slot>_p<point> and y_i<sensor>_t<slot>_p<point>:
    the columns a plan is read back from (import-solution)."""
    names = {}
    for t, p in zip(*np.nonzero(st.x_col >= 0), strict=True):
        names[f"x_t{t}_p{p}"] = int(st.x_col[t, p])
    for u in range(st.n_uploads):
        names[f"y_i{st.up_sensor[u]}_t{st.up_slot[u]}_p{st.up_point[u]}"] = int(st.up_col[u])
    return names


def worth_name(k: int, count: int) -> str:
    """The name of worth column k of ``count``: z_t<slot> per slot (the mean objectives), or z."""
    return f"z_t{k + 1}" if count > 1 else "z"


def new_highs(verbose: bool = False):
    """A Highs object; HiGHS prints its banner on stdout when the first one is made, whatever
    its options, so unless ``verbose`` that one construction writes to /dev/null."""
    import highspy

    if verbose:
        return highspy.Highs()
    sys.stdout.flush()
    saved, devnull = os.dup(1), os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        return highspy.Highs()
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)
