"""Several robots (MODEL.md section 10) in the time-expanded MILP: the layer beside the
one-robot path rows of formulation.py (docs/milp.md, "Several robots").

The upload structure is the one-robot one over the points that *some* robot can stand on
(models/uploads.py). Its x columns become the occupancy o[p, t] of a point, and its y[i, s, p]
reads "sensor i uploads in slot s to the robot on point p": at most one robot stands on a point
in a slot, so the robot is implied and y needs no robot index. Added here, after those columns:

- x[k, p, t] binary: robot k stands on p in slot t (p on some legal plan of robot k alone:
  ``lattice.build(instance.robot(k)).on_some_plan(t)``);
- f[k, t, p, q] in [0, 1]: robot k moves from p in slot t-1 to q in slot t (q = p: it stays).
  Integral once x is: from the one point of slot t-1 to the one point of slot t.

Rows: occupancy o[p, t] = sum_k x[k, p, t] with o <= 1 (the vertex rule; with it the one-robot
TDMA row sum_i y[i, t, p] <= o[p, t] is "each robot at most one upload a slot"), flow in and out
of every x, each robot's budget over its stays, one row per edge and slot against swaps, and
one per sensor and slot against a sensor uploading to two robots.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from voiopt.grid import lattice as lattice_mod
from voiopt.solvers.milp.solution import best_level_of, upload_ids
from voiopt.solvers.milp.uploads import Structure


@dataclass(frozen=True, eq=False)
class FleetColumns:
    """The columns of the fleet layer: robot positions and moves."""

    x_col: np.ndarray  # (K, T, n) column of x[k, p, t], -1 where robot k never stands
    arc_robot: np.ndarray  # (F,) k
    arc_slot: np.ndarray  # (F,) t in 1..T-1: the move from slot t-1 to slot t
    arc_from: np.ndarray  # (F,) p
    arc_to: np.ndarray  # (F,) q
    arc_col: np.ndarray  # (F,)

    @property
    def n_robots(self) -> int:
        return self.x_col.shape[0]

    def name(self, names: list[str], st: Structure) -> None:
        """o_t<t>_p<p> (occupancy, the structure's x columns), x_r<k>_t<t>_p<p> and
        f_r<k>_t<t>_p<p>_q<q> (robot k's move from p in slot t-1 to q in slot t)."""
        for t, p in zip(*np.nonzero(st.x_col >= 0), strict=True):
            names[st.x_col[t, p]] = f"o_t{t}_p{p}"
        for k, t, p in zip(*np.nonzero(self.x_col >= 0), strict=True):
            names[self.x_col[k, t, p]] = f"x_r{k}_t{t}_p{p}"
        for k, t, p, q, c in zip(self.arc_robot, self.arc_slot, self.arc_from, self.arc_to, self.arc_col, strict=True):
            names[c] = f"f_r{k}_t{t}_p{p}_q{q}"


def path(st: Structure, tr) -> tuple[np.ndarray, np.ndarray, np.ndarray, FleetColumns]:
    """Columns (lower, upper, integrality of every column so far) and rows of the fleet's
    paths; the caller adds the TDMA rows over the occupancy columns."""
    inst = st.instance
    K, T, n = inst.n_robots, st.horizon, st.n_points
    lats = [lattice_mod.build(inst.robot(k)) for k in range(K)]
    reach = np.stack([lat.on_some_plan(np.arange(T)) for lat in lats])  # (K, T, n)
    x_col = np.full((K, T, n), -1, dtype=np.int64)
    x_col[reach] = st.n_base + np.arange(int(reach.sum()))
    fc = _arcs(x_col, reach, lats[0].neighbors, st.n_base + int(reach.sum()))
    n_cols = int(fc.arc_col[-1]) + 1 if len(fc.arc_col) else st.n_base + int(reach.sum())

    lower, upper = np.zeros(n_cols), np.ones(n_cols)
    integrality = np.ones(n_cols, dtype=np.int8)
    integrality[st.x_col[st.x_col >= 0]] = 0  # o: the sum of binaries
    integrality[fc.arc_col] = 0  # f: integral once x is
    for k, lat in enumerate(lats):
        lower[x_col[k, 0, lat.start]] = 1.0

    _occupancy_rows(st, x_col, tr)
    _flow_rows(fc, tr)
    for k, lat in enumerate(lats):
        min_stays = max(0, T - 1 - lat.budget)
        stays = fc.arc_col[(fc.arc_robot == k) & (fc.arc_from == fc.arc_to)]
        if min_stays:
            tr.add(np.zeros(len(stays), dtype=np.int64), stays, 1.0, np.array([float(min_stays)]), np.inf,
                   name=f"max_moves_r{k}_")
    _swap_rows(fc, tr)
    _sensor_once_rows(st, tr)
    return lower, upper, integrality, fc


def _arcs(x_col: np.ndarray, reach: np.ndarray, neighbors: np.ndarray, first_col: int) -> FleetColumns:
    """Every move (and stay) of robot k between points it can stand on in slots t-1 and t.
    The robots share the area and its blocked points, so they share ``neighbors``."""
    K, T, _ = reach.shape
    parts = []
    for k in range(K):
        t0, p = np.nonzero(reach[k, :-1])
        q = neighbors[p]  # (m, 5), -1 off the area or into a blocked point
        ok = (q >= 0) & reach[k, t0[:, None] + 1, np.maximum(q, 0)]
        r, j = np.nonzero(ok)
        parts.append((np.full(len(r), k), t0[r] + 1, p[r], q[r, j]))
    robot, slot, frm, to = (np.concatenate([a[c] for a in parts]).astype(np.int64) for c in range(4))
    return FleetColumns(x_col, robot, slot, frm, to, first_col + np.arange(len(robot)))


def _occupancy_rows(st: Structure, x_col: np.ndarray, tr) -> None:
    """o[p, t] - sum_k x[k, p, t] = 0; o's upper bound 1 is the vertex rule."""
    t_o, p_o = np.nonzero(st.x_col >= 0)
    row_of = np.full(st.x_col.shape, -1, dtype=np.int64)
    row_of[t_o, p_o] = np.arange(len(t_o))
    k, t, p = np.nonzero(x_col >= 0)
    tr.add(np.concatenate([np.arange(len(t_o)), row_of[t, p]]),
           np.concatenate([st.x_col[t_o, p_o], x_col[k, t, p]]),
           np.concatenate([np.ones(len(t_o)), -np.ones(len(k))]), np.zeros(len(t_o)), 0.0, name="occupancy")


def _flow_rows(fc: FleetColumns, tr) -> None:
    """x[k, p, t] = sum of the moves into p at t (t >= 1), = sum of the moves out of p at t+1
    (t <= T-2): each robot's path, with the start fixed in slot 0."""
    K, T, _ = fc.x_col.shape
    for name, slots, lag, point in (("flow_in", slice(1, T), 0, fc.arc_to), ("flow_out", slice(0, T - 1), 1, fc.arc_from)):
        sel = np.zeros(fc.x_col.shape, dtype=bool)
        sel[:, slots] = fc.x_col[:, slots] >= 0
        row_of = np.full(fc.x_col.shape, -1, dtype=np.int64)
        row_of[sel] = np.arange(int(sel.sum()))
        arc_row = row_of[fc.arc_robot, fc.arc_slot - lag, point]
        tr.add(np.concatenate([np.arange(int(sel.sum())), arc_row]),
               np.concatenate([fc.x_col[sel], fc.arc_col]),
               np.concatenate([np.ones(int(sel.sum())), -np.ones(len(arc_row))]),
               np.zeros(int(sel.sum())), 0.0, name=name)


def _swap_rows(fc: FleetColumns, tr) -> None:
    """sum_k f[k, t, p, q] + f[k, t, q, p] <= 1 for each edge {p, q} and slot t that two robots
    could cross in opposite directions. Two robots crossing it the same way would share p in
    slot t-1, which the occupancy bound already forbids; so the row is exactly "no swap"."""
    move = np.flatnonzero(fc.arc_from != fc.arc_to)
    lo = np.minimum(fc.arc_from[move], fc.arc_to[move])
    hi = np.maximum(fc.arc_from[move], fc.arc_to[move])
    n = int(hi.max()) + 1 if len(hi) else 1
    key = fc.arc_slot[move] * n * n + lo * n + hi
    keys, row = np.unique(key, return_inverse=True)
    forward = fc.arc_from[move] < fc.arc_to[move]
    both = (np.bincount(row, forward, len(keys)) > 0) & (np.bincount(row, ~forward, len(keys)) > 0)
    pairs = np.unique(np.stack([row, fc.arc_robot[move]]), axis=1)
    robots = np.bincount(pairs[0], minlength=len(keys))
    keep = both & (robots >= 2)
    new_row = np.cumsum(keep) - 1
    m = keep[row]
    tr.add(new_row[row[m]], fc.arc_col[move[m]], 1.0, np.full(int(keep.sum()), -np.inf), 1.0, name="swap")


def _sensor_once_rows(st: Structure, tr) -> None:
    """sum_p y[i, s, p] <= 1: a sensor uploads to at most one robot in a slot."""
    key = st.up_sensor * st.horizon + st.up_slot
    keys, row, count = np.unique(key, return_inverse=True, return_counts=True)
    keep = count >= 2
    new_row = np.cumsum(keep) - 1
    m = keep[row]
    tr.add(new_row[row[m]], st.up_col[m], 1.0, np.full(int(keep.sum()), -np.inf), 1.0, name="sensor_once")


# ------------------------------------------------------------------ plans and columns


def plan_from_columns(st: Structure, fc: FleetColumns, col_value: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(K, T) point indices and schedule (-1 = none) from the x and y values of a solution;
    an upload goes to the robot on its point, and non-improving uploads are dropped."""
    xv = np.where(fc.x_col >= 0, col_value[np.maximum(fc.x_col, 0)], -np.inf)
    idx = xv.argmax(axis=2)
    sched = np.full(idx.shape, -1, dtype=np.int64)
    for u in np.flatnonzero(col_value[st.up_col] > 0.5):
        k = np.flatnonzero(idx[:, st.up_slot[u]] == st.up_point[u])
        if len(k):
            sched[k[0], st.up_slot[u]] = st.up_sensor[u]
    return idx, clean_schedule(st, idx, sched)


def clean_schedule(st: Structure, idx: np.ndarray, sched: np.ndarray) -> np.ndarray:
    """The fleet's uploads that raise their sensor's best level, slot by slot; of two robots
    serving one sensor in a slot only the better upload is kept (section 10's rule)."""
    out = np.full(sched.shape, -1, dtype=np.int64)
    best = np.full(st.n_sensors, -1, dtype=np.int64)
    for s in range(sched.shape[1]):
        chosen: dict[int, tuple[int, int]] = {}  # sensor -> (level, robot)
        for k in np.flatnonzero(sched[:, s] >= 0):
            i = int(sched[k, s])
            hit = np.flatnonzero((st.up_slot == s) & (st.up_point == idx[k, s]) & (st.up_sensor == i))
            level = int(st.up_level[hit[0]]) if len(hit) else -1
            if level > best[i] and level > chosen.get(i, (-1, -1))[0]:
                chosen[i] = (level, int(k))
        for i, (level, k) in chosen.items():
            best[i] = level
            out[k, s] = i
    return out


def path_columns(st: Structure, fc: FleetColumns, n_cols: int, idx: np.ndarray,
                 sched: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A column vector with o, x, f and y of a fleet plan (its uploads cleaned first), and the
    (T+1, N) best level of each sensor before each slot, for the H columns."""
    idx = np.asarray(idx, dtype=np.int64)
    sched = clean_schedule(st, idx, np.asarray(sched, dtype=np.int64))
    col = np.zeros(n_cols)
    slots = np.arange(st.horizon)
    ids = []
    for k in range(fc.n_robots):
        col[st.x_col[slots, idx[k]]] = 1.0
        col[fc.x_col[k, slots, idx[k]]] = 1.0
        ids += upload_ids(st, idx[k], sched[k])
    moved = (fc.arc_from == idx[fc.arc_robot, fc.arc_slot - 1]) & (fc.arc_to == idx[fc.arc_robot, fc.arc_slot])
    col[fc.arc_col[moved]] = 1.0
    col[st.up_col[np.asarray(ids, dtype=np.int64)]] = 1.0
    return col, best_level_of(st, ids)
