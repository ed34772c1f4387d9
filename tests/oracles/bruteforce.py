"""An independent exact solver for tiny instances, written from MODEL.md alone.

It shares no code with voiopt beyond reading the instance's fields: its own lattice, its own
VoI formula (plain math), its own dynamics, and an exhaustive memoised search over the full
state (slot, position, every age, every effective distance). The four objectives all split
into "what happened so far" combined with "the best future from this state", so the search
is exact. Use it only where T and the lattice are small.
"""

from __future__ import annotations

import math
from functools import cache

OBJECTIVE_SENSE = {"min-voi": "max", "mean-min-voi": "max", "max-aoi": "min", "mean-max-aoi": "min"}


def _voi(inst, i, aoi, q):
    s = inst.sensors[i]
    g0 = 10 ** (inst.channel.g0_db / 10)
    n0 = 10 ** (inst.channel.noise_dbm_per_hz / 10) / 1000
    b = inst.channel.bandwidth_hz
    x = s.power_w * g0 * s.rho**aoi / (b * n0 * q * q + s.power_w * g0)
    return -b * math.log1p(-x) / math.log(2)


def brute_force(inst, objective):
    """Return (optimal value, positions, schedule) by exhaustive search."""
    step = inst.step
    nx = int(math.floor(inst.width / step + 1e-9)) + 1
    ny = int(math.floor(inst.height / step + 1e-9)) + 1
    start = (round(inst.start[0] / step), round(inst.start[1] / step))
    T, N, dth = inst.horizon, len(inst.sensors), inst.channel.d_th

    def dist(i, k, l):
        sx, sy = inst.sensors[i].position
        return math.hypot(k * step - sx, l * step - sy)

    def moves(k, l):
        for dk, dl in ((0, 0), (0, 1), (0, -1), (1, 0), (-1, 0)):
            if 0 <= k + dk < nx and 0 <= l + dl < ny:
                yield k + dk, l + dl

    def slot_score(aoi, q):
        if objective in ("min-voi", "mean-min-voi"):
            return min(_voi(inst, i, aoi[i], q[i]) for i in range(N))
        return max(aoi)

    maximise = OBJECTIVE_SENSE[objective] == "max"
    combine = {
        "min-voi": min,
        "mean-min-voi": lambda a, b: a + b,
        "max-aoi": max,
        "mean-max-aoi": lambda a, b: a + b,
    }[objective]
    pick = max if maximise else min

    @cache
    def best(t, k, l, aoi, q):
        """Best combined score of slots t+1..T from the state in slot t; plus the decision."""
        options = []
        uploads = [None] + [i for i in range(N) if dist(i, k, l) <= dth + 1e-9]
        for u in uploads:
            na = tuple(1 if i == u else aoi[i] + 1 for i in range(N))
            nq = tuple(dist(i, k, l) if i == u else q[i] for i in range(N))
            here = slot_score(na, nq)
            if t + 1 == T:
                options.append((here, u, None))
                continue
            for k2, l2 in moves(k, l):
                fut, _, _ = best(t + 1, k2, l2, na, nq)
                options.append((combine(here, fut), u, (k2, l2)))
        return pick(options, key=lambda o: o[0])

    aoi0 = tuple(s.initial_aoi for s in inst.sensors)
    q0 = tuple(inst.initial_distance(i) for i in range(N))
    value, _, _ = best(0, *start, aoi0, q0)
    # reconstruct
    positions, schedule = [], []
    k, l, aoi, q = *start, aoi0, q0
    for t in range(T):
        _, u, nxt = best(t, k, l, aoi, q)
        positions.append([k * step, l * step])
        schedule.append(u)
        aoi = tuple(1 if i == u else aoi[i] + 1 for i in range(N))
        q = tuple(dist(i, k, l) if i == u else q[i] for i in range(N))
        if nxt is not None:
            k, l = nxt
    if objective.startswith("mean"):
        value /= T
    best.cache_clear()
    return value, {"positions": positions, "schedule": schedule}
