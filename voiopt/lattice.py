"""Lattice points, the five moves, in-range sets and reachability (MODEL.md section 2).

Points are numbered k * ny + l for the point (k * step, l * step).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from voiopt.instance import LATTICE_TOL, Instance

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
        k, l = round(x / self.step), round(y / self.step)
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


def shape(instance: Instance) -> tuple[int, int]:
    """(nx, ny): the lattice points per row and per column (MODEL.md section 2)."""
    step = instance.step
    return (math.floor(instance.width / step + LATTICE_TOL) + 1, math.floor(instance.height / step + LATTICE_TOL) + 1)


def n_points(instance: Instance) -> int:
    nx, ny = shape(instance)
    return nx * ny


def unservable_sensors(instance: Instance) -> list[int]:
    """The sensors with no lattice point within d_th: no plan can ever schedule them."""
    lat = build(instance)
    return [i for i in range(instance.n_sensors) if not lat.in_range[i].any()]


@lru_cache(maxsize=64)
def build(instance: Instance) -> Lattice:
    step = instance.step
    nx, ny = shape(instance)
    k, l = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    coords = np.stack([k.ravel(), l.ravel()], axis=1).astype(np.int64)
    points = coords * step
    nb = coords[:, None, :] + MOVES[None, :, :]
    ok = (nb[..., 0] >= 0) & (nb[..., 0] < nx) & (nb[..., 1] >= 0) & (nb[..., 1] < ny)
    neighbors = np.where(ok, nb[..., 0] * ny + nb[..., 1], -1)
    sx, sy = instance.start
    start = round(sx / step) * ny + round(sy / step)
    pos = np.array([s.position for s in instance.sensors], dtype=float)
    distance = np.hypot(points[None, :, 0] - pos[:, None, 0], points[None, :, 1] - pos[:, None, 1])
    in_range = distance <= instance.channel.d_th + LATTICE_TOL
    for arr in (coords, points, neighbors, distance, in_range):
        arr.setflags(write=False)
    return Lattice(step, nx, ny, coords, points, neighbors, start, distance, in_range)
