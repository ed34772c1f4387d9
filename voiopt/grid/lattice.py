"""Lattice points, the five moves, in-range sets and reachability (MODEL.md section 2).

Points are numbered k * ny + l for the point (k * step, l * step).
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from voiopt.core.instance import LATTICE_TOL, Instance, lattice_shape, point_index
from voiopt.grid import paths

UNREACHABLE = paths.UNREACHABLE  # steps_from's distance where there is no way
MOVES = paths.MOVES


@dataclass(frozen=True, eq=False)
class Lattice:
    step: float
    nx: int
    ny: int
    coords: np.ndarray  # (n, 2) integer (k, l)
    points: np.ndarray  # (n, 2) metres
    neighbors: np.ndarray  # (n, 5) point index after each move, -1 where it would leave the area
    start: int  # index of the start point
    distance: np.ndarray  # (N, n) distance from each sensor to each point
    in_range: np.ndarray  # (N, n) bool: distance <= d_th
    horizon: int  # T
    blocked: np.ndarray  # (n,) bool: points never stood on (MODEL.md section 9)
    end: int  # index of the end point, or -1 if the instance has none
    budget: int  # the most moves a plan can make: min(max_moves, T - 1)
    to_end: np.ndarray  # (n,) fewest moves to end around blocked points (0 everywhere without an end)

    @property
    def n_points(self) -> int:
        return self.nx * self.ny

    def index(self, x: float, y: float) -> int | None:
        """Index of the lattice point (x, y), or None if it is not one."""
        qx, qy = x / self.step, y / self.step
        if not (-1 <= qx <= self.nx and -1 <= qy <= self.ny):  # also NaN and inf (round would raise)
            return None
        k, l = round(qx), round(qy)
        if abs(k * self.step - x) > LATTICE_TOL or abs(l * self.step - y) > LATTICE_TOL:
            return None
        if not (0 <= k < self.nx and 0 <= l < self.ny):
            return None
        return k * self.ny + l

    @cached_property
    def from_start(self) -> np.ndarray:
        """(n,) fewest moves from start around blocked points (computed when first asked)."""
        out = self.steps_from(self.start)
        out.setflags(write=False)
        return out

    @property
    def has_blocked(self) -> bool:
        return bool(self.blocked.any())

    def move(self, p: int, q: int) -> int:
        """The move (0 stay, then N, S, E, W: the columns of ``neighbors``) from point p to q,
        one step (or none) apart."""
        return next(m for m in range(5) if self.neighbors[p, m] == q)

    def steps_from(self, p) -> np.ndarray:
        """Fewest moves from point p (or the nearest of several points) to every point, around
        blocked points: the Manhattan distance on an open lattice; paths.UNREACHABLE where
        there is no way."""
        return paths.steps(self.nx, self.ny, self.blocked if self.has_blocked else None, p)

    def walk_home(self, p: int, slots: int) -> list[int]:
        """The points of the next ``slots`` slots after p: the fewest moves to end, then
        staying (just staying without an end). From a point where ``can_finish`` holds, this
        keeps every rule of MODEL.md section 9; it is how a stopped heuristic ends its plan."""
        out = []
        for _ in range(slots):
            if self.to_end[p] > 0:
                p = next(int(q) for q in self.neighbors[p] if q >= 0 and self.to_end[q] == self.to_end[p] - 1)
            out.append(p)
        return out

    def on_some_plan(self, t) -> np.ndarray:
        """Bool mask (or (len(t), n) for an array of slots) of the points the entity can stand on
        in slot t of some legal plan: reached from start in <= t moves, with end still reachable
        in the slots left, and the two legs within the budget."""
        t = np.asarray(t)[..., None]
        d0, d1 = self.from_start, self.to_end
        ok = (d0 <= t) & (d1 <= self.horizon - 1 - t)
        return ok & ((d0 + d1 <= self.budget) if self.end >= 0 else (d0 <= self.budget))

    def reachable(self, t: int) -> np.ndarray:
        """Bool mask of the points within t moves of start, around blocked points."""
        return self.from_start <= t

    def can_finish(self, q: np.ndarray | int, t: int, moves_used) -> np.ndarray | bool:
        """Whether standing on q in slot t after ``moves_used`` moves still leaves a legal way
        to end (within the slots left and the budget): the mask of section 9's rules."""
        left = np.minimum(self.horizon - 1 - t, self.budget - np.asarray(moves_used))
        return (self.to_end[q] <= left) & (np.asarray(moves_used) <= self.budget)


def n_points(instance: Instance) -> int:
    """The number of lattice points (MODEL.md section 2), without building the lattice."""
    nx, ny = lattice_shape(instance.width, instance.height, instance.step)
    return nx * ny


def unservable_sensors(instance: Instance) -> list[int]:
    """The sensors with no lattice point within d_th that can be stood on: no plan can ever
    schedule them. With blocked points this asks the lattice; without, it is the same test
    as ``build(instance).in_range[i].any()``, without building the lattice: the
    nearest lattice point is among the 3 x 3 around the rounded position (the lattice is a
    full grid), and the distances are computed exactly as ``build`` computes them."""
    if instance.blocked:
        lat = build(instance)
        return np.flatnonzero(~(lat.in_range & ~lat.blocked).any(axis=1)).tolist()
    step = instance.step
    nx, ny = lattice_shape(instance.width, instance.height, step)
    pos = np.array([s.position for s in instance.sensors], dtype=float).reshape(-1, 2)
    near = np.array([-1, 0, 1], dtype=np.int64)
    ks = np.clip(np.rint(pos[:, 0] / step).astype(np.int64)[:, None] + near, 0, nx - 1)  # (N, 3)
    ls = np.clip(np.rint(pos[:, 1] / step).astype(np.int64)[:, None] + near, 0, ny - 1)
    d = np.hypot((ks * step)[:, :, None] - pos[:, 0, None, None], (ls * step)[:, None, :] - pos[:, 1, None, None])
    ok = (d <= instance.channel.d_th + LATTICE_TOL).any(axis=(1, 2))
    return np.flatnonzero(~ok).tolist()


def cheap(instance: Instance, work: float = 5e7) -> bool:
    """Whether building every robot's lattice, with its distances to every sensor, is cheap: a
    check that needs them (``stranded_sensors``) stays quick for ``voiopt validate`` on the
    largest instances the loader accepts."""
    return n_points(instance) * max(1, instance.n_sensors) * instance.n_robots <= work


def stranded_sensors(instance: Instance) -> list[int]:
    """The sensors that have points in range, yet no legal plan can upload: no robot can stand on
    any of them in any slot (MODEL.md section 9: reached from start, then end in the slots and
    moves left; ``Lattice.on_some_plan``). Their packet only ages, whatever the plan, so their
    worths are fixed: such a sensor often decides the objective alone."""
    never = set(unservable_sensors(instance))
    stood = None
    for k in range(instance.n_robots):
        lat = build(instance.robot(k))
        # some slot t has d0 <= t <= T - 1 - d1, within the budget (which is at most T - 1)
        ok = (lat.from_start + lat.to_end <= lat.budget) & ~lat.blocked
        stood = ok if stood is None else stood | ok
    reach = (lat.in_range & stood[None, :]).any(axis=1)
    return [i for i in range(instance.n_sensors) if i not in never and not reach[i]]


# build() keeps recent lattices, like an lru_cache, but bounded in bytes too: one lattice can
# take up to 100 MB (the caps of instance.py), and 64 of those would not fit.
_CACHE: OrderedDict[Instance, Lattice] = OrderedDict()
_CACHE_ENTRIES = 64
_CACHE_BYTES = 256 * 2**20
_LOCK = threading.Lock()


def _nbytes(lat: Lattice) -> int:
    return sum(a.nbytes for a in (lat.coords, lat.points, lat.neighbors, lat.distance, lat.in_range, lat.blocked,
                                  lat.to_end))


def build(instance: Instance) -> Lattice:
    """The lattice of an instance (cached: the same instance gives the same object)."""
    with _LOCK:
        lat = _CACHE.get(instance)
        if lat is not None:
            _CACHE.move_to_end(instance)
            return lat
    lat = _build(instance)
    with _LOCK:
        _CACHE[instance] = lat
        while len(_CACHE) > 1 and (len(_CACHE) > _CACHE_ENTRIES or sum(map(_nbytes, _CACHE.values())) > _CACHE_BYTES):
            _CACHE.popitem(last=False)
    return lat


build.cache_clear = _CACHE.clear  # as with lru_cache


def _build(instance: Instance) -> Lattice:
    """Every array is written in place, so the peak memory is the lattice itself plus a few
    MB (73 bytes a point, 8 more with an end, 9 more a point and sensor: at most 100 MB within the caps)."""
    step = instance.step
    nx, ny = lattice_shape(instance.width, instance.height, step)
    n = nx * ny
    coords = np.empty((n, 2), dtype=np.int64)
    grid = coords.reshape(nx, ny, 2)
    grid[:, :, 0] = np.arange(nx, dtype=np.int64)[:, None]
    grid[:, :, 1] = np.arange(ny, dtype=np.int64)[None, :]
    points = coords * step
    start = point_index(instance.start, step, ny)
    pos = np.array([s.position for s in instance.sensors], dtype=float).reshape(-1, 2)
    distance = np.empty((len(pos), n))
    block = 2**16  # distances are computed in blocks of this many entries
    rows = max(1, block // n)
    for i in range(0, len(pos), rows):
        for b in range(0, n, block):
            e = min(n, b + block)
            np.hypot(points[None, b:e, 0] - pos[i : i + rows, 0, None], points[None, b:e, 1] - pos[i : i + rows, 1, None],
                     out=distance[i : i + rows, b:e])
    in_range = distance <= instance.channel.d_th + LATTICE_TOL
    blocked = np.zeros(n, dtype=bool)
    for b in instance.blocked:
        blocked[point_index(b, step, ny)] = True
    neighbors = paths.neighbors(nx, ny, blocked)
    end = -1
    to_end = np.broadcast_to(np.int64(0), (n,))  # no end: zero moves left to make, and no memory
    if instance.end is not None:
        end = point_index(instance.end, step, ny)
        to_end = paths.steps(nx, ny, blocked if blocked.any() else None, end)
    T = instance.horizon
    budget = T - 1 if instance.max_moves is None else min(T - 1, instance.max_moves)
    for arr in (coords, points, neighbors, distance, in_range, blocked, to_end):
        arr.setflags(write=False)
    return Lattice(step, nx, ny, coords, points, neighbors, start, distance, in_range, T, blocked, end, budget, to_end)
