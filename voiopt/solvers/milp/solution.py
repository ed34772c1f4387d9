"""Between plans and MILP columns: read a plan off a solution, and back."""

from __future__ import annotations

import numpy as np

from voiopt.solvers.milp.uploads import Structure


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
    return best_level_of(st, upload_ids(st, idx, sched))


def best_level_of(st: Structure, ids) -> np.ndarray:
    """(T+1, N): the highest level any of the uploads ``ids`` of sensor i reached before slot t
    (-1: none); the uploads of one robot's plan or of a whole fleet's."""
    T, N = st.horizon, st.n_sensors
    best = np.full((T + 1, N), -1, dtype=np.int64)
    for u in ids:
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
