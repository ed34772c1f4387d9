"""Lattice points, the five moves, in-range sets and reachability (MODEL.md section 2).

Points are numbered k * ny + l for the point (k * step, l * step).
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from voiopt.instance import LATTICE_TOL, Instance, lattice_shape

MOVES = np.array([(0, 0), (0, 1), (0, -1), (1, 0), (-1, 0)], dtype=np.int64)


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

    def steps_from(self, p: int) -> np.ndarray:
        """Fewest moves from point p to every point (Manhattan distance on the full grid)."""
        return np.abs(self.coords - self.coords[p]).sum(axis=1)

    def reachable(self, t: int) -> np.ndarray:
        """Bool mask of the points the entity can stand on in slot t."""
        return self.steps_from(self.start) <= t


def n_points(instance: Instance) -> int:
    """The number of lattice points (MODEL.md section 2), without building the lattice."""
    nx, ny = lattice_shape(instance.width, instance.height, instance.step)
    return nx * ny


def unservable_sensors(instance: Instance) -> list[int]:
    """The sensors with no lattice point within d_th: no plan can ever schedule them.

    The same test as ``build(instance).in_range[i].any()``, without building the lattice: the
    nearest lattice point is among the 3 x 3 around the rounded position (the lattice is a
    full grid), and the distances are computed exactly as ``build`` computes them."""
    step = instance.step
    nx, ny = lattice_shape(instance.width, instance.height, step)
    pos = np.array([s.position for s in instance.sensors], dtype=float).reshape(-1, 2)
    near = np.array([-1, 0, 1], dtype=np.int64)
    ks = np.clip(np.rint(pos[:, 0] / step).astype(np.int64)[:, None] + near, 0, nx - 1)  # (N, 3)
    ls = np.clip(np.rint(pos[:, 1] / step).astype(np.int64)[:, None] + near, 0, ny - 1)
    d = np.hypot((ks * step)[:, :, None] - pos[:, 0, None, None], (ls * step)[:, None, :] - pos[:, 1, None, None])
    ok = (d <= instance.channel.d_th + LATTICE_TOL).any(axis=(1, 2))
    return np.flatnonzero(~ok).tolist()


# build() keeps recent lattices, like an lru_cache, but bounded in bytes too: one lattice can
# take up to 90 MB (the caps of instance.py), and 64 of those would not fit.
_CACHE: OrderedDict[Instance, Lattice] = OrderedDict()
_CACHE_ENTRIES = 64
_CACHE_BYTES = 256 * 2**20
_LOCK = threading.Lock()


def _nbytes(lat: Lattice) -> int:
    return sum(a.nbytes for a in (lat.coords, lat.points, lat.neighbors, lat.distance, lat.in_range))


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
    MB (72 bytes a point, 9 more a point and sensor: at most 90 MB within the caps)."""
    step = instance.step
    nx, ny = lattice_shape(instance.width, instance.height, step)
    n = nx * ny
    coords = np.empty((n, 2), dtype=np.int64)
    grid = coords.reshape(nx, ny, 2)
    grid[:, :, 0] = np.arange(nx, dtype=np.int64)[:, None]
    grid[:, :, 1] = np.arange(ny, dtype=np.int64)[None, :]
    points = coords * step
    # neighbour of (k, l) after move (dk, dl): (k + dk) * ny + (l + dl), -1 off the area
    neighbors = np.empty((n, len(MOVES)), dtype=np.int64)
    nb = neighbors.reshape(nx, ny, len(MOVES))
    for j, (dk, dl) in enumerate(MOVES.tolist()):
        np.add(np.arange(nx, dtype=np.int64)[:, None] * ny + dk * ny + dl, np.arange(ny, dtype=np.int64)[None, :],
               out=nb[:, :, j])
        if dk:
            nb[nx - 1 if dk > 0 else 0, :, j] = -1
        if dl:
            nb[:, ny - 1 if dl > 0 else 0, j] = -1
    sx, sy = instance.start
    start = round(sx / step) * ny + round(sy / step)
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
    for arr in (coords, points, neighbors, distance, in_range):
        arr.setflags(write=False)
    return Lattice(step, nx, ny, coords, points, neighbors, start, distance, in_range)
