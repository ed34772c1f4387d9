"""The exact expected objectives of a plan under lossy links (MODEL.md section 11).

A plan is open-loop, and each upload involves one sensor, so the sensors' processes are
independent. Each objective is an extreme over sensors of a per-sensor *worth* W_i (V_i, or
-A_i for the AoI objectives, so that every objective is E[min over i of W_i]):

- per slot t, sensor i's worth depends only on which of its uploads before t last succeeded
  (or none): upload j with probability p_j * prod over its later uploads before t of (1 - p);
- over all slots, sensor i's worth is the minimum over the segments between its successful
  uploads of the worth at each segment's last slot (a worth only falls between uploads); its
  survival P(W_i >= c) comes from a DP over its uploads for every candidate value c at once;
- E[min over i of W_i] for independent W_i is u_1 + sum over k of (u_k - u_(k-1)) prod_i
  P(W_i >= u_k), over the sorted values u_k of all sensors: a sum of non-negative terms,
  so no cancellation.

Every VoI is computed by ``physics.voi``, as the simulator does. An instance that is not
lossy (no ``links``, or every probability 1) gets ``voiopt.evaluate``'s metrics themselves.
"""

from __future__ import annotations

import numpy as np

from voiopt import objectives
from voiopt.core import physics
from voiopt.core.instance import Instance
from voiopt.core.links import is_lossy, success_probability
from voiopt.core.plan import FleetPlan, Plan
from voiopt.core.simulate import check_plan, simulate_indices
from voiopt.grid import lattice as lattice_mod
from voiopt.objectives import Worth

BLOCK = 1 << 22  # entries of one step of the bottleneck DP (uploads x candidate values), at most


def expected_metrics(instance: Instance, plan: Plan | FleetPlan | dict) -> dict[str, float]:
    """The four objectives' exact expectations over the upload outcomes of ``plan`` (a Plan, a
    FleetPlan, or a dict holding one); PlanError if the plan is illegal. Without losses these
    are the simulator's metrics, bit for bit."""
    if not isinstance(plan, (Plan, FleetPlan)):
        plan = Plan.from_dict(plan)
    idx, sched = check_plan(instance, plan)
    if not is_lossy(instance):
        return simulate_indices(instance, idx, sched).metrics
    uploads = sensor_uploads(instance, idx, sched)
    T = instance.horizon
    worst = {}  # (worth, per_slot) -> E[...] of the min over sensors of their worth
    for kind in Worth:
        worth = _SensorWorth(instance, kind)
        per_slot = [[_slot_distribution(worth, i, ups, t) for i, ups in enumerate(uploads)] for t in range(1, T + 1)]
        worst[kind, True] = sum(expected_min(dists) for dists in per_slot) / T
        worst[kind, False] = expected_min([_bottleneck_survival(worth, i, ups, T) for i, ups in enumerate(uploads)])
    # an objective maximises the min worth (V), or minimises the max age (worth -A)
    return {o.name: float(worst[o.worth, o.per_slot] * (1 if o.maximise else -1)) for o in objectives.BY_NAME.values()}

def sensor_uploads(instance: Instance, idx: np.ndarray, sched: np.ndarray) -> list[np.ndarray]:
    """Each sensor's uploads in a checked plan, in slot order, as a (U, 3) array of rows
    (slot, distance, success probability): one robot's (T,) arrays or a fleet's (K, T)."""
    lat = lattice_mod.build(instance)
    sched2, idx2 = np.atleast_2d(sched), np.atleast_2d(idx)
    out = []
    for i in range(instance.n_sensors):
        k, t = np.nonzero(sched2 == i)  # a sensor uploads to at most one robot per slot
        order = np.argsort(t, kind="stable")
        k, t = k[order], t[order]
        d = lat.distance[i, idx2[k, t]]
        p = np.asarray(success_probability(instance, i, d), dtype=float).reshape(-1)
        out.append(np.column_stack([t.astype(float), d, p]))
    return out


class _SensorWorth:
    """A sensor's worth at an age and effective distance: V (bit/s) or -A."""

    def __init__(self, instance: Instance, kind: Worth) -> None:
        self.instance, self.kind = instance, kind

    def __call__(self, i: int, age: np.ndarray, dist: np.ndarray) -> np.ndarray:
        age = np.asarray(age, dtype=float)
        if self.kind is Worth.AOI:
            return -age
        s = self.instance.sensors[i]
        return np.asarray(physics.voi(age, dist, s.rho, s.power_w, self.instance.channel), dtype=float).reshape(age.shape)

    def start(self, i: int) -> tuple[float, float]:
        """The virtual upload of the initial state: made in slot -A_i(0) at q_i(0)."""
        return -float(self.instance.sensors[i].initial_aoi), self.instance.initial_distance(i)


def _slot_distribution(worth: _SensorWorth, i: int, ups: np.ndarray, t: int) -> tuple[np.ndarray, np.ndarray]:
    """Sensor i's worth in row t as a survival function: (sorted distinct values, P(W >= value))."""
    before = ups[ups[:, 0] < t]
    s0, q0 = worth.start(i)
    slots = np.concatenate([[s0], before[:, 0]])
    dists = np.concatenate([[q0], before[:, 1]])
    p = np.concatenate([[1.0], before[:, 2]])
    later_fail = np.ones(len(p))  # prod over later uploads (before t) of 1 - p
    if len(p) > 1:
        later_fail[:-1] = np.cumprod((1.0 - p[1:])[::-1])[::-1]
    prob = p * later_fail
    keep = prob > 0
    values = worth(i, t - slots[keep], dists[keep])
    return survival(values, prob[keep])


def survival(values: np.ndarray, prob: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A discrete distribution as (sorted distinct values, P(X >= value)), the tail sums taken
    directly (never 1 minus a sum)."""
    u, inverse = np.unique(values, return_inverse=True)
    mass = np.zeros(len(u))
    np.add.at(mass, inverse.reshape(-1), prob)
    return u, np.cumsum(mass[::-1])[::-1]


def expected_min(dists: list[tuple[np.ndarray, np.ndarray]]) -> float:
    """E[min_i X_i] of independent discrete X_i, each given as (sorted values, P(X_i >= value)):
    u_1 + sum_k (u_k - u_(k-1)) prod_i P(X_i >= u_k) over the union of the values."""
    u = np.unique(np.concatenate([v for v, _ in dists]))
    tail = np.ones(len(u))
    for values, surv in dists:
        pos = np.searchsorted(values, u, side="left")  # the smallest own value >= u
        own = np.zeros(len(u))
        inside = pos < len(values)
        own[inside] = surv[pos[inside]]
        tail *= own
    if len(u) == 1:
        return float(u[0])
    return float(u[0] + np.sum(np.diff(u) * tail[1:]))


def _bottleneck_survival(worth: _SensorWorth, i: int, ups: np.ndarray, T: int) -> tuple[np.ndarray, np.ndarray]:
    """Sensor i's worth over all rows 1..T, min over t of W_i(t), as a survival function.

    Upload 0 is the virtual upload of the initial state (p = 1), 1..U the plan's. Between two
    successes j < k the worth falls over rows s_j + 1 .. s_k, so that segment's minimum is
    seg(j, k) = worth(s_k - s_j, d_j) (no rows, no constraint, when s_k = 0); after the last
    success j it is fin(j) = worth(T - s_j, d_j). For a candidate value c, f_k(c) = P(upload k
    is a success and every segment so far has worth >= c) = p_k sum_j f_j(c) fail(j, k)
    [seg(j, k) >= c], with fail(j, k) = prod over j < l < k of (1 - p_l); then
    P(W >= c) = sum_j f_j(c) fail(j, U + 1) [fin(j) >= c]."""
    s0, q0 = worth.start(i)
    slots = np.concatenate([[s0], ups[:, 0]])
    dists = np.concatenate([[q0], ups[:, 1]])
    p = np.concatenate([[1.0], ups[:, 2]])
    n = len(p)
    fail = np.zeros((n, n + 1))  # fail[j, k] = prod_{j < l < k} (1 - p_l), for k > j
    for j in range(n):
        fail[j, j + 1:] = np.cumprod(np.concatenate([[1.0], 1.0 - p[j + 1:]]))
    ages = slots[None, :] - slots[:, None]  # [j, k] = s_k - s_j
    seg = np.full((n, n), np.inf)
    upper = np.triu(np.ones((n, n), dtype=bool), 1)
    jj, kk = np.nonzero(upper)
    seg[jj, kk] = worth(i, ages[jj, kk], dists[jj])
    seg[0, slots < 1] = np.inf  # the initial segment has no rows when the first success is in slot 0
    fin = worth(i, T - slots, dists)
    cand = np.unique(np.concatenate([seg[np.isfinite(seg)], fin]))
    surv = np.empty(len(cand))
    step = max(1, BLOCK // max(1, n))
    for lo in range(0, len(cand), step):
        c = cand[lo:lo + step]
        f = np.zeros((n, len(c)))
        f[0] = 1.0
        for k in range(1, n):
            ok = seg[:k, k, None] >= c[None, :]
            f[k] = p[k] * np.sum(f[:k] * (fail[:k, k, None] * ok), axis=0)
        surv[lo:lo + step] = np.sum(f * (fail[:, n, None] * (fin[:, None] >= c[None, :])), axis=0)
    return cand, surv
