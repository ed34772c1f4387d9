"""Where robots and obstacles may stand (MODEL.md sections 2, 9 and 10): the lattice's
geometry, and the validation of start, end, blocked and robots for instance.py.

Every message names the field path (``robots[1].end``) and the value, and where no plan can
exist it says why (a BFS around the blocked points, paths.steps).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from voiopt.grid import paths
from voiopt.runtime.checker import Checker, join_path, show

LATTICE_TOL = 1e-9  # absolute tolerance for "is a lattice point" and "within d_th"
MAX_LATTICE_POINTS = 10**6
MAX_ROBOTS = 64  # robots of MODEL.md section 10: far above what any method can plan jointly


def on_lattice(x: float, step: float) -> bool:
    q = x / step
    if not math.isfinite(q):
        return False
    k = round(q)
    return abs(k * step - x) <= LATTICE_TOL


def point_index(p: tuple[float, float], step: float, ny: int) -> int:
    """The index k * ny + l of the lattice point p = (k * step, l * step) (MODEL.md section 2)."""
    return round(p[0] / step) * ny + round(p[1] / step)


def lattice_shape(width: float, height: float, step: float) -> tuple[float, float]:
    """(nx, ny) of MODEL.md section 2: floor(width / step) + 1 by floor(height / step) + 1.
    Exact ints when the lattice is within the cap; otherwise floats, possibly inf, computed
    without building or overflowing anything."""
    out = []
    for r in (width / step, height / step):
        out.append(math.floor(r + LATTICE_TOL) + 1 if r <= MAX_LATTICE_POINTS else r + 1)
    return out[0], out[1]


_ROBOT_FIELDS = frozenset({"start", "end", "max_moves"})


def check_robots(ck: Checker, d: dict, width, height, step, area_ok: bool) -> list[tuple[str, tuple]]:
    """The robots as (path prefix, (start, end, max_moves)): the top-level start, end and max_moves of one robot,
    or the ``robots`` list of MODEL.md section 10 (distinct starts, distinct ends). A
    one-entry list is the same instance as the flat form. Empty (with failures) when invalid."""
    if "robots" not in d:
        entries = [("", d)]
    else:
        for key in ("end", "max_moves"):
            if key in d:
                ck.fail(key, f"must not be given at the top level with robots (give it per robot), got {show(d[key])}")
        raw = d["robots"]
        if not isinstance(raw, list) or not raw or len(raw) > MAX_ROBOTS:
            ck.fail("robots", f"must be a list of 1 to {MAX_ROBOTS} robots {{start, end?, max_moves?}}, got {show(raw)}")
            return []
        entries = []
        for k, r in enumerate(raw):
            if ck.obj(r, f"robots[{k}]", _ROBOT_FIELDS, {"start"}) is not None and "start" in r:
                entries.append((f"robots[{k}]", r))
    out = []
    for path, r in entries:
        start = lattice_point(ck, r, "start", path, width, height, step, area_ok) if "start" in r else None
        end = lattice_point(ck, r, "end", path, width, height, step, area_ok) if "end" in r else None
        max_moves = ck.integer(r, "max_moves", path, None, 0)
        if start is not None and ("end" not in r or end is not None) and ("max_moves" not in r or max_moves is not None):
            out.append((path, (start, end, max_moves)))
    for key, what in (("start", "slot 0"), ("end", "the last slot")):
        seen: dict[tuple[float, float], str] = {}
        for path, r in out:
            p = r[0] if key == "start" else r[1]
            if p is None:
                continue
            if p in seen:
                ck.fail(join_path(path, key), f"{show_xy(p)} is also {seen[p]}.{key}: two robots may never share a lattice "
                                          f"point, so no plan could place both there in {what}")
            seen[p] = path
    return out if len(out) == len(entries) else []


def show_xy(p: tuple[float, float]) -> str:
    """A point as a message shows it: [4, 4], [0.5, 1]."""
    return f"[{p[0]:g}, {p[1]:g}]"


def in_area(x: float, y: float, width: float, height: float) -> bool:
    """Whether (x, y) lies in the area [0, width] x [0, height], to LATTICE_TOL."""
    return -LATTICE_TOL <= x <= width + LATTICE_TOL and -LATTICE_TOL <= y <= height + LATTICE_TOL


def lattice_point(ck: Checker, d: dict, key: str, path: str, width, height, step, area_ok: bool,
                   what: str | None = None) -> tuple[float, float] | None:
    """A lattice point inside the area (snapped to the lattice), or None and a failure."""
    where = what or join_path(path, key)
    point = ck.point(d, key, path, where)
    if point is None or not area_ok:
        return None
    x, y = point
    if not in_area(x, y, width, height):
        return ck.fail(where, f"must lie in the area [0, {width:g}] x [0, {height:g}], got {show(list(point))}")
    if not (on_lattice(x, step) and on_lattice(y, step)):
        return ck.fail(where, f"must be a lattice point (multiples of step {step:g}), got {show(list(point))}")
    return (round(x / step) * step, round(y / step) * step)


def check_blocked(ck: Checker, raw: Any, width, height, step, area_ok: bool,
                   n_points: int | None) -> tuple[tuple[float, float], ...]:
    """MODEL.md section 9: a list of distinct lattice points inside the area."""
    if not isinstance(raw, list):
        ck.fail("blocked", f"must be a list of lattice points [x, y], got {show(raw)}")
        return ()
    if n_points is not None and len(raw) >= n_points:
        ck.fail("blocked", f"must leave some of the {n_points} lattice points free, got {len(raw)} blocked points")
        return ()
    fast = _blocked_at_once(raw, width, height, step) if area_ok else None
    if fast is not None:
        return fast
    out, seen = [], {}  # one by one, for the messages
    for j, v in enumerate(raw):
        p = lattice_point(ck, {"p": v}, "p", "", width, height, step, area_ok, what=f"blocked[{j}]")
        if p is None:
            continue
        key = (round(p[0] / step), round(p[1] / step))
        if key in seen:
            ck.fail(f"blocked[{j}]", f"{show_xy(p)} is listed twice (also blocked[{seen[key]}])")
            continue
        seen[key] = j
        out.append(p)
    return tuple(out)


def _blocked_at_once(raw: list, width: float, height: float, step: float) -> tuple[tuple[float, float], ...] | None:
    """The blocked points checked as one array (a list of 10**5 points in a fraction of a
    second), or None when any entry breaks a rule: then the one-by-one check names it."""
    if not all(type(p) is list and len(p) == 2 and type(p[0]) in (int, float) and type(p[1]) in (int, float)
               for p in raw):
        return None
    try:
        arr = np.array(raw, dtype=float).reshape(-1, 2)
    except (OverflowError, ValueError):
        return None
    if not np.isfinite(arr).all():
        return None
    x, y = arr[:, 0], arr[:, 1]
    if not ((x >= -LATTICE_TOL) & (x <= width + LATTICE_TOL) & (y >= -LATTICE_TOL) & (y <= height + LATTICE_TOL)).all():
        return None
    k = np.rint(arr / step)
    if not (np.abs(k * step - arr) <= LATTICE_TOL).all():
        return None
    ny = lattice_shape(width, height, step)[1]
    keys = k[:, 0].astype(np.int64) * ny + k[:, 1].astype(np.int64)
    ordered = np.sort(keys)
    if (ordered[1:] == ordered[:-1]).any():
        return None
    return tuple(map(tuple, (k * step).tolist()))


def check_route(ck: Checker, width, height, step, horizon, start, end, blocked, max_moves, path: str = "") -> None:
    """Start and end are free, and some legal plan exists: ``end`` is within reach of start
    in at most T - 1 moves and max_moves, around the blocked points (a BFS, paths.steps)."""
    nx, ny = lattice_shape(width, height, step)
    k = np.rint(np.array(blocked, dtype=float).reshape(-1, 2) / step).astype(np.int64)
    keys = k[:, 0] * ny + k[:, 1]
    mask = np.zeros(nx * ny, dtype=bool)
    mask[keys] = True
    for name, p in (("start", start), ("end", end)):
        if p is not None:
            for j in np.flatnonzero(keys == point_index(p, step, ny)).tolist():
                what = f"the {name} point" if not path else f"{path}.{name}"
                ck.fail(f"blocked[{j}]", f"{show_xy(blocked[j])} is {what}, which must stay free")
    if ck.errors or end is None:
        return
    moves = paths.steps(nx, ny, mask, point_index(start, step, ny))[point_index(end, step, ny)]
    allowed = horizon - 1 if max_moves is None else min(horizon - 1, max_moves)
    why = f"horizon {horizon} allows {horizon - 1}" if allowed == horizon - 1 else f"max_moves is {max_moves}"
    around = " around the blocked points" if blocked else ""
    if moves >= paths.UNREACHABLE:
        ck.fail(join_path(path, "end"), f"{show_xy(end)} is not reachable from start {show_xy(start)}: the blocked points wall it off")
    elif moves > allowed:
        ck.fail(join_path(path, "end"), f"{show_xy(end)} is not reachable within {_moves(allowed)} ({why}): it is {_moves(moves)} "
                       f"from start {show_xy(start)}{around}")


def _moves(k: int) -> str:
    return f"{k} move" if k == 1 else f"{k} moves"


def joint_decided(width, height, step, horizon, blocked, robots) -> bool:
    """Whether validation decided that the robots have a joint plan (``check_together`` accepted
    it by the exact table, or no robot has an end); False where it passed undecided."""
    if len(robots) < 2 or all(r.end is None for r in robots):
        return True
    from voiopt.grid import joint

    nx, ny = lattice_shape(width, height, step)
    return joint.decides(nx * ny, len(robots), horizon, tuple(r.max_moves for r in robots))


def check_together(ck: Checker, width, height, step, horizon, blocked, robots) -> None:
    """Several robots that could each keep their rules alone can still have no joint plan
    (MODEL.md sections 9 and 10): two robots in a corridor cannot pass each other. Decided
    exactly by the table of joint points that can still finish (joint.possible) on fleets
    small enough for it (joint.decides); on larger ones, a pair of robots with no joint plan
    proves it (joint.pairs_possible); others pass, undecided (``voiopt validate`` says so), and
    milp, dp and Q-learning prove it themselves (status ``infeasible``, docs/model.md)."""
    if len(robots) < 2 or all(r[1] is None for _, r in robots):
        return  # without an end every robot may stay at its own start
    from voiopt.grid import joint  # numba: only for a fleet with an end

    nx, ny = lattice_shape(width, height, step)
    blocked = tuple(sorted(point_index(b, step, ny) for b in blocked))
    starts = tuple(point_index(r[0], step, ny) for _, r in robots)
    ends = tuple(-1 if r[1] is None else point_index(r[1], step, ny) for _, r in robots)
    moves = tuple(r[2] for _, r in robots)
    ok = joint.possible(nx, ny, blocked, starts, ends, moves, horizon)
    if ok is None:  # too large to decide at once: two robots that cannot keep their rules together prove it
        ok = joint.pairs_possible(nx, ny, blocked, starts, ends, moves, horizon)
    if ok is False:
        rules = ", ".join(f"{path}: {show_xy(r[0])}" + ("" if r[1] is None else f" to {show_xy(r[1])}")
                          + ("" if r[2] is None else f", max_moves {r[2]}") for path, r in robots)
        budgets = " and max_moves" if any(r[2] is not None for _, r in robots) else ""
        ck.fail("robots", f"no legal joint plan: each robot can reach its end alone, but in {horizon} slots the robots "
                          f"cannot all keep their ends{budgets} without two of them sharing or swapping points "
                          f"({rules}; MODEL.md section 10)")
