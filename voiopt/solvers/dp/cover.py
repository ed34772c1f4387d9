"""The cover bound of dp (docs/dp.md, "Sensors that no walk reaches together").

A plan uploads a sensor only while the robot stands on a point in its range. If no walk of the
robot that the slots and the budget allow (from start, and on to the end if there is one)
stands in the range of every sensor of a set S, then every plan leaves some sensor of S never
uploaded, and that sensor's worth is the one of its held packet in every slot. The slots'
minimum is at most that worth, so the optimum is at most the largest over S of the sensors'
worths without an upload, accumulated over the slots (summed, or their least), in the
kernels' units. A set of one is a sensor stranded alone (``lattice.stranded_sensors``); on a
factory floor whose budget is short of the closed walk past all of them (90 moves against
80), the AoI objectives' optimum is the idle plan's, and this bound proves it.

The bound is the least over the sets S_k of the k sensors of the smallest accumulated worths
without an upload: any set S that no walk covers lies inside the S_k of its own largest worth,
which then no walk covers either. Which sets a walk covers comes from one exact dynamic
programme over (sensors covered, point) pairs, Held and Karp's, on the points in range of some
sensor, with the fewest moves between them around blocked points. One robot only.
"""

from __future__ import annotations

import numpy as np

from voiopt.core.instance import Instance
from voiopt.grid import lattice as lattice_mod
from voiopt.grid import paths
from voiopt.solvers.labels.tables import Tables

MAX_WORK = 5e7  # 2^N x points^2 of the exact programme: about a second; beyond it, no bound
MAX_SENSORS = 14  # its loop over the 2^N sets is Python's
MAX_POINTS = 1000  # points in range of some sensor: their table of moves is points^2 floats


def bound(instance: Instance, tab: Tables) -> float:
    """The cover bound in the kernels' (maximised) units; +inf where every set is covered by
    some walk, or with several robots. Where the exact programme would cost too much (over
    MAX_WORK, MAX_SENSORS or MAX_POINTS), only the sets of one sensor: the stranded ones."""
    from voiopt.solvers.labels import kernels as core

    if instance.fleet:
        return np.inf
    lat = lattice_mod.build(instance)
    N = instance.n_sensors
    idle = tab.W[np.arange(N), tab.initial_rank.astype(np.int64), 1:]  # (N, T): each sensor never uploaded
    worth = idle.sum(axis=1) if tab.mode == core.SUM else idle.min(axis=1)
    points = np.flatnonzero(lat.in_range.any(axis=0) & ~lat.blocked)
    if N > MAX_SENSORS or len(points) > MAX_POINTS or 2.0 ** N * len(points) ** 2 > MAX_WORK:
        alone = lattice_mod.unservable_sensors(instance) + lattice_mod.stranded_sensors(instance)  # sets of one
        return float(worth[alone].min()) if alone else np.inf
    if len(points) == 0:  # no sensor can ever upload: every plan is the idle plan's value
        return float(worth.min())
    legs = _Legs(lat, points, N)
    if _greedy_cover(legs) <= lat.budget:  # every set is covered: nothing to bound
        return np.inf
    walk = _fewest_moves(legs, N)
    mask = 0
    for i in np.argsort(worth, kind="stable"):  # S_k: the k sensors of the smallest worths
        mask |= 1 << int(i)
        if walk[mask] > lat.budget:
            return float(worth[i])
    return np.inf


class _Legs:
    """The points in range of some sensor: the fewest moves between them (inf where blocked
    off), from start to each, from each to the end (0 without one), and the bit mask of the
    sensors in range of each."""

    def __init__(self, lat: lattice_mod.Lattice, points: np.ndarray, N: int):
        self.between = np.array([lat.steps_from(int(p))[points] for p in points], dtype=float)
        self.start = lat.from_start[points].astype(float)
        for a in (self.between, self.start):
            a[(a < 0) | (a >= paths.UNREACHABLE)] = np.inf
        self.home = lat.to_end[points].astype(float) if lat.end >= 0 else np.zeros(len(points))
        self.home_from_start = float(lat.to_end[lat.start]) if lat.end >= 0 else 0.0
        bits = (1 << np.arange(N, dtype=np.int64))[:, None]
        self.cover = (lat.in_range[:, points].astype(np.int64) * bits).sum(axis=0)


def _fewest_moves(legs: _Legs, N: int) -> np.ndarray:
    """walk[S]: the fewest moves of a walk from start that stands in the range of every sensor
    of S, then goes to the end (Held-Karp over the sets and the point last stood on). A point
    covers every sensor in its range at once; moves between points are fewest-move ones, so a
    walk need not stop anywhere else."""
    n = len(legs.start)
    at = np.full((1 << N, n), np.inf)  # at[S, j]: fewest moves to stand on j having covered S
    np.minimum.at(at, (legs.cover, np.arange(n)), legs.start)
    for mask in range(1 << N):  # a step only adds sensors: every set is final before it is read
        row = at[mask]
        if np.isinf(row).all():
            continue
        onward = (row[:, None] + legs.between).min(axis=0)
        np.minimum.at(at, (mask | legs.cover, np.arange(n)), onward)
    best = (at + legs.home[None, :]).min(axis=1)  # covered exactly S, then home
    best[0] = min(best[0], legs.home_from_start)  # the empty set: straight home
    for bit in range(N):  # a walk that covers more covers S too: the least over supersets
        has = (np.arange(1 << N) >> bit) & 1 == 1
        best[~has] = np.minimum(best[~has], best[has])
    return best


def _greedy_cover(legs: _Legs) -> float:
    """Moves of one walk that covers every sensor that has a point in range: from start to the
    nearest point that covers a sensor not yet covered, and so on, then home. An upper bound
    on the fewest: when it fits the budget, every set is covered."""
    want = int(np.bitwise_or.reduce(legs.cover))
    here, got, total, k = legs.start, 0, 0.0, -1
    while got != want:
        onward = np.where((legs.cover & ~got) != 0, here, np.inf)  # to a point that covers more
        k = int(np.argmin(onward))
        if not np.isfinite(onward[k]):  # the sensors left are walled off from here
            return np.inf
        total += here[k]
        got |= int(legs.cover[k])
        here = legs.between[k]
    return total + (float(legs.home[k]) if k >= 0 else legs.home_from_start)
