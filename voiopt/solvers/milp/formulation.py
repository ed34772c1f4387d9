"""The time-expanded MILP of the path and upload schedule: its rows and columns.

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
- z[t] (or a single z), the objective's per-slot minimum worth, in units of ``scale``;
- s[p, t] binary, only with a binding ``max_moves``: the entity stays at p from slot t-1 to t.

The field rules of MODEL.md section 9 shape the graph: x exists only where p lies on some legal
plan (blocked points never, the last slot only at ``end``), and ``max_moves`` is one row over
the stay variables.

The worth of sensor i in slot t is w0_i(t) + sum_l inc_l(t) H[i, t, l] with telescoping
increments inc_l(t) = w_l(t) - w_(l-1)(t) of the precomputed lookup values w_l(t).

``min-voi`` and ``max-aoi`` are solved by bisection over the finite set of candidate worths with
the pure 0-1 covering models of :func:`build_covering`; the single-z model of :func:`build`
is the same problem as one MILP (used by export and the Pyomo cross-check).
"""

from __future__ import annotations

import math

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.grid import lattice as lattice_mod
from voiopt.runtime.stop import halt_if_asked
from voiopt.solvers.milp import fleet
from voiopt.solvers.milp.model import LevelTerms, Model, Triplets
from voiopt.solvers.milp.uploads import Structure, structure


def _path_rows(st: Structure, tr: Triplets) -> None:
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
    _tdma_rows(st, tr)
    _budget_rows(st, tr)


def _tdma_rows(st: Structure, tr: Triplets) -> None:
    """sum_i y[i, t, p] <= x[p, t]: upload only where you stand, one sensor a slot (for a fleet
    x[p, t] is the occupancy of p, at most one robot)."""
    if st.n_uploads:
        key = st.up_slot * st.n_points + st.up_point
        keys, row = np.unique(key, return_inverse=True)
        t_k, p_k = keys // st.n_points, keys % st.n_points
        rows = np.concatenate([row, np.arange(len(keys))])
        cols = np.concatenate([st.up_col, st.x_col[t_k, p_k]])
        vals = np.concatenate([np.ones(st.n_uploads), -np.ones(len(keys))])
        tr.add(rows, cols, vals, np.full(len(keys), -np.inf), 0.0, name="tdma")


def _path(st: Structure, tr: Triplets) -> tuple[np.ndarray, np.ndarray, np.ndarray, fleet.FleetColumns | None]:
    """Columns (bounds, integrality) and rows of the path and schedule: one robot's, or a
    fleet's (models/milp/fleet.py, with these TDMA rows over its occupancy columns)."""
    if st.instance.fleet:
        *cols, fleet_cols = fleet.path(st, tr)
        _tdma_rows(st, tr)
        return (*cols, fleet_cols)
    lower, upper, integrality = _base_columns(st)
    _path_rows(st, tr)
    return lower, upper, integrality, None


def _budget_rows(st: Structure, tr: Triplets) -> None:
    """max_moves (MODEL.md section 9): s[p, t] <= x[p, t-1], s[p, t] <= x[p, t] and
    sum s >= (T - 1) - max_moves. With x integral, s[p, t] can be 1 only when the entity stays
    at p from slot t-1 to t, so the sum counts the slots without a move; x alone stays binary."""
    S = len(st.stay_col)
    if not st.min_stays:
        return
    e = np.arange(S)
    for lag in (1, 0):
        tr.add(np.concatenate([e, e]), np.concatenate([st.stay_col, st.x_col[st.stay_slot - lag, st.stay_point]]),
               np.concatenate([np.ones(S), -np.ones(S)]), np.full(S, -np.inf), 0.0, name=f"stay_lag{lag}_")
    tr.add(np.zeros(S, dtype=np.int64), st.stay_col, 1.0, np.array([float(st.min_stays)]), np.inf, name="max_moves")


def _base_columns(st: Structure) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bounds and integrality of x, y and the stay variables, all binary (x of the start in
    slot 0 fixed to 1). The stays are integral anyway once x is; declared continuous, they
    led HiGHS 1.16's presolve to a "Solve error" on a covering problem with a tight budget."""
    n = st.n_base
    lower, upper = np.zeros(n), np.ones(n)
    lower[st.x_col[0, lattice_mod.build(st.instance).start]] = 1.0
    integrality = np.ones(n, dtype=np.int8)
    return lower, upper, integrality


def default_scale(st: Structure, objective: str) -> float:
    """A worth unit that makes the objective O(1): the mean over slots of the cap on the slot's
    least worth (an upper bound on mean-min-voi; ``Structure.min_worth_cap``). AoI objectives
    use 1. The solver passes its warm start's value instead; ``export`` uses this."""
    if st.kind == "aoi":
        return 1.0
    cap = st.min_worth_cap()[1:]
    ref = float(cap.mean()) if objectives.get(objective).per_slot else float(cap.min())
    return ref if ref > 0 and math.isfinite(ref) else 1.0


STOP_SLOTS = 256  # slots of level_terms between two checks of the stop rule


def level_terms(st: Structure, per_slot: bool, stop=None) -> LevelTerms:
    """H entries (i, t, l) for live levels l whose lower neighbour is still below the cap on z
    (higher levels cannot raise min_i worth), with telescoping, capped increments. A slot costs
    numpy calls over its levels (3 s at T = 2243 for 4 sensors), so ``stop`` is checked every
    STOP_SLOTS slots: voiopt.runtime.stop.Stopped."""
    T, N = st.horizon, st.n_sensors
    cap_t = st.min_worth_cap()[1:]  # z_t <= cap_t
    floor_t = st.worth0[1:].min(axis=1)  # z_t >= floor_t: every sensor keeps at least its packet
    if not per_slot:
        cap_t = np.full(T, cap_t.min())
        floor_t = np.full(T, floor_t.min())
    h_i, h_t, h_l, h_inc = [], [], [], []
    for i in range(N):
        w = st.level_worth[i]
        for t in range(1, T + 1):
            if t % STOP_SLOTS == 0:
                halt_if_asked(stop)
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


# A worth unit (scale) at least the largest z cap / SCALE_RANGE, so that z's bounds and the
# coefficients of its rows stay within SCALE_RANGE of 1. A warm start far below what the sensors
# can be worth (1e-37 against 3 bit/s, found by an outside oracle) made them 1e8 and more, and
# HiGHS "proved" the warm start optimal 8 orders of magnitude below the optimum; at 1e6 its
# bounds still fell up to 5e-4 below the optimum on such networks. Ordinary networks have caps
# of 2 to 450 warm-start values, so their scale is the warm start's.
SCALE_RANGE = 1e4


def build(instance: Instance, objective: str, *, scale: float | None = None, stop=None) -> Model:
    """The full MILP for ``objective``: per-slot z for the mean objectives, one z for the
    min/max objectives. Maximises (1/T) sum z_t, or z, in worth units of ``scale`` (raised to
    the largest z cap / SCALE_RANGE if below it). voiopt.runtime.stop.Stopped if ``stop`` says stop
    while its largest parts (the worths of the uploads, the rows of the uploads) are built."""
    kind = objectives.get(objective).worth
    st = structure(instance, kind, stop)
    T = st.horizon
    per_slot = objectives.get(objective).per_slot
    scale = float(scale) if scale is not None else default_scale(st, objective)
    if not (scale > 0 and math.isfinite(scale)):
        raise ValueError(f"scale: must be a positive finite number, got {scale!r}")
    lt = level_terms(st, per_slot, stop)
    if kind == "voi" and len(lt.cap):  # z's bounds and coefficients within SCALE_RANGE of 1 (see SCALE_RANGE)
        scale = max(scale, float(lt.cap.max()) / SCALE_RANGE)
    h_i, h_t, h_inc = lt.sensor, lt.slot, lt.increment

    tr = Triplets()
    lower, upper, base_integrality, fleet_cols = _path(st, tr)
    n_base = len(lower)
    h_col = n_base + np.arange(len(h_i))
    n_z = T if per_slot else 1
    z_cols = n_base + len(h_i) + np.arange(n_z)

    # H[i, t, l] - H[i, t', l] - sum_{s in [t', t-1], level(u) >= l} y_u <= 0, t' = the
    # previous slot with an H of the same (i, l), or 0 (and no H term) for the first
    e = np.arange(len(h_i))
    has_prev = lt.previous >= 0
    eu, uu = lt.uploads(st, stop)
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
        z_cols, np.concatenate(tr.z_of), lt, h_col, tuple(tr.blocks), fleet_cols,
    )
    return model


def build_covering(instance: Instance, objective: str, threshold: float, stop=None) -> Model | None:
    """The 0-1 feasibility problem "every sensor's worth is >= threshold in every slot"
    (``threshold`` a worth: V for min-voi, -A for max-aoi), or None if some (i, t) cannot
    reach it at all. For each (i, t) whose initial packet is below the threshold: some upload
    of i before t at a level whose worth at t is >= threshold. voiopt.runtime.stop.Stopped if
    ``stop`` says stop while the worths of the uploads are computed."""
    kind = objectives.get(objective).worth
    st = structure(instance, kind, stop)
    tr = Triplets()
    lower, upper, integrality, fleet_cols = _path(st, tr)
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
        np.concatenate(tr.z_of), row_blocks=tuple(tr.blocks), fleet=fleet_cols,
    )
