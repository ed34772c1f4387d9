"""A subset's pattern database: a bound on each label of dp's bounded pass from the best future
of the same state in a network of fewer sensors (docs/dp.md, "Pattern databases").

Take a subset S of the sensors and a threshold z (an incumbent's value). A bounded pass over S
alone with incumbent z keeps, at each slot and point, the labels (S-states) that dominance and
the bounds leave. Backwards over those layers each kept S-label K gets f(K), an upper bound on
the best its state can add in the later slots, over S: the best over its children of the
child's slot term plus f of a kept label at the child's point whose ranks (and moves left, with
a budget) are at least the child's; or, if no kept label has them, z minus the child's
accumulated value.

Why that last case is sound, by induction over the slots: every S-prefix reaching (t, p) is
either matched by a kept label at (t, p) with at least its value and ranks (and moves left),
or none of its completions is worth more than z over S. The start holds; a matched prefix's
step is taken by its kept match too (an upload that would not raise the match's rank is left
out, and the child without it is at least as good), and that child is kept, dominated by a kept
label, or dropped by a bound that no completion beats z. (A dominating label that the costlier
bound drops afterwards takes the dominated child with it: its bound covers that child's
completions too. Children cut because they can no longer reach ``end`` within the slots and
moves left have no completion, and ``_futures`` cuts them the same way.) So a prefix with no
kept label of at least its ranks is in the second case. The subset's own pass collapses
sensors too: its collapsed index is above every real rank of a sensor of S (a sensor's
candidates are its own, the same in S and in the whole), so a collapsed lane matches any rank,
and f of such a label is the future of a state in which that sensor counts +inf, which only
raises the slot terms.

A label L of the whole network at (t, p) with accumulated value a has, for any completion, a
later minimum over all sensors that is at most the minimum over S, and its S-part is an
S-prefix. So L's best completion is at most a + f(K) for every kept K at (t, p) with ranks (and
moves left) at least L's ranks of S; and if there is none, its S-part has no completion above
z over S, which is at least its value over all sensors: L cannot beat z. A sensor of S that
L has collapsed stands for a rank it does not hold, so such a label keeps the bounds it has,
except in a slot that the subset's pass never reached, where no S-prefix beats z and every
label is dropped. The bound needs the sum objectives (the mean ones): the best future adds to a.

The bound holds for the completions worth more than z, not for the others: a label whose
completions are all at most z may get a bound below its value, or -inf. So a pattern built at
z serves only a pass whose threshold is at least z, and such a pass, if stopped, bounds the
optimum by the larger of z and its open labels' bounds (dp._bounded does both).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from voiopt.core.instance import Instance
from voiopt.runtime.jit import njit
from voiopt.solvers.dp import subsets
from voiopt.solvers.labels.tables import Tables, watched, watched_all


@dataclass
class Pattern:
    """The kept S-labels of each slot (grouped by point) and their best futures."""

    sensors: np.ndarray  # S, as indices of the whole network's sensors
    ranks: list[np.ndarray]  # per slot: (labels, |S|) int16
    left: list[np.ndarray]  # per slot: moves left
    off: list[np.ndarray]  # per slot: (n + 1,) offsets of each point's labels
    future: list[np.ndarray]  # per slot: f of each label; each point's labels in ascending order of f (_by_future)
    budget_lane: int
    threshold: float  # internal units: z
    labels: int
    worth: np.ndarray  # the subset's own W and initial ranks: another network may use the pattern if they agree
    initial_rank: np.ndarray

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for part in (self.ranks, self.left, self.off, self.future) for a in part)

    def bound(self, stop, t: int, ranks: np.ndarray, acc: np.ndarray, pos: np.ndarray, left: np.ndarray,
              ub: np.ndarray, collapsed: int) -> np.ndarray:
        """The labels' bounds tightened by this pattern (-inf where no label of it has their ranks)."""
        if t >= len(self.ranks):  # no S-label reached slot t: no S-prefix beats z
            return np.full_like(ub, -np.inf)
        return watched(stop, _tighten, ranks, acc, pos, left, ub, self.sensors, collapsed, self.budget_lane,
                       self.ranks[t], self.left[t], self.off[t], self.future[t])

    def within(self, sensors: list[int], whole: Tables) -> Pattern | None:
        """The same pattern for a network (``whole``) of which its subset is the sensors
        ``sensors`` (same lattice, robot, slots and rules), or None if their ranks differ."""
        if not _same_ranks(self.worth, self.initial_rank, whole, sensors):
            return None
        return replace(self, sensors=np.asarray(sensors, dtype=np.int64))


def build(instance: Instance, objective: str, sensors: list[int], whole: Tables, threshold: float, stop,
          threads: int, search, tables) -> tuple[Pattern | None, object]:
    """The pattern of ``sensors`` at ``threshold`` (internal units), and the outcome of its pass
    (a plan of the subset found above the threshold is a plan of the whole). None if the pass
    or the futures were stopped, or if the subset's ranks do not mean what the whole's do."""
    sub = subsets.restricted(instance, sensors, f"{instance.name}-pattern{len(sensors)}")
    tab = tables(sub)
    if not _same_ranks(tab.W, tab.initial_rank, whole, sensors):
        return None, None
    layers: list[tuple] = []
    out = search(tab, threshold, record=layers, stop=stop, threads=threads)
    if not out.complete:
        return None, out
    own = from_layers(layers, tab, threshold, stop, threads)
    return (None if own is None else own.within(sensors, whole)), out


@dataclass
class Recorded:
    """A complete pass over a network (``tab``) at ``threshold`` (internal units) that recorded
    its ``layers`` (``_dp_search.search``): a pattern database of all its sensors, made when needed
    (``from_layers``). Any complete pass will do, whatever bounds (patterns included) pruned
    it: a label they dropped has no completion above its threshold."""

    layers: list[tuple]
    tab: Tables
    threshold: float
    work: float = 0.0  # future_work: the scans its pattern's futures take


def future_work(layers: list[tuple], tab: Tables) -> float:
    """The scans the futures of ``from_layers`` make, about: per kept label, its children (one
    per upload option and move) times the kept labels of the next slot at the child's point.
    About 2.3e8 a second on the 2-core machine of docs/dp.md: a subset of 7 sensors of a
    network of 16 whose pass kept 349k labels needed 7.8e9, 34 s; 117k labels, 4e8, 1.4 s."""
    work = 0.0
    n = tab.neighbors.shape[0]
    options = 1.0 + tab.in_range_count[:n]
    for t in range(len(layers) - 1):
        here = np.diff(layers[t][4]).astype(float)
        nxt = np.append(np.diff(layers[t + 1][4]).astype(float), 0.0)  # index -1 (no neighbour): 0 labels
        work += float(np.sum(here * options * nxt[tab.neighbors].sum(axis=1)))
    return work


def from_layers(layers: list[tuple], tab: Tables, threshold: float, stop, threads: int = 1) -> Pattern | None:
    """The pattern of a complete pass over a network (``tab``) at ``threshold`` (internal units)
    that recorded its ``layers`` (``Recorded``): of all its sensors, as indices of its own.
    None if the futures were stopped. A slot's labels are independent of one another, so its
    futures are computed in ``threads`` parts at once, the same whatever ``threads`` is."""
    T = tab.up_rank.shape[0]
    futures: list[np.ndarray] = [np.empty(0)] * len(layers)
    nxt = (layers[0][0][:0], layers[0][2][:0], np.zeros_like(layers[0][4]), np.empty(0))
    for t in range(len(layers) - 1, -1, -1):
        ranks, acc, left, pos, off = layers[t]
        cuts = np.linspace(0, len(acc), max(1, min(threads, len(acc) // 1024 + 1)) + 1).astype(np.int64)
        calls = [(t, T, ranks[lo:hi], acc[lo:hi], left[lo:hi], pos[lo:hi], tab.neighbors, tab.up_rank,
                  tab.in_range_list, tab.in_range_count, tab.W, tab.to_end, tab.budget_lane, threshold, *nxt)
                 for lo, hi in zip(cuts[:-1], cuts[1:], strict=True)]
        parts = watched_all(stop, _futures, calls, threads)
        if stop.check() is not None:  # the stop is remembered: a kernel halted by it returned part of f
            return None
        futures[t] = _by_future(np.concatenate(parts) if len(parts) > 1 else parts[0], off, ranks, acc, left)
        nxt = (ranks, left, off, futures[t])
    return Pattern(np.arange(tab.W.shape[0], dtype=np.int64), [x[0] for x in layers], [x[2] for x in layers],
                   [x[4] for x in layers], futures, tab.budget_lane, threshold,
                   sum(len(x[1]) for x in layers), tab.W, tab.initial_rank)


def _by_future(future: np.ndarray, off: np.ndarray, *same: np.ndarray) -> np.ndarray:
    """Each point's labels (``off``) in ascending order of f, so that the first whose ranks
    match has the least f (``_least_future``): ``same``, the layer's other arrays, are put in
    that order in place (the layer stays the same set of labels, and another ``from_layers``
    gives the same futures); returns f in that order."""
    point = np.repeat(np.arange(len(off) - 1), np.diff(off))
    order = np.lexsort((future, point))
    for a in same:
        a[:] = a[order]
    return future[order]


def _same_ranks(W: np.ndarray, initial_rank: np.ndarray, whole: Tables, sensors: list[int]) -> bool:
    """A sensor's ranks are its own candidates' order, so they agree between the subset (its
    worth table ``W`` and initial ranks) and the whole network; checked on the worth tables,
    below each one's collapsed row."""
    R = min(W.shape[1], whole.W.shape[1]) - 1
    return bool(np.array_equal(W[:, :R], whole.W[sensors, :R]) and W.shape[1] <= whole.W.shape[1]
                and np.array_equal(initial_rank, whole.initial_rank[sensors]))


@njit(cache=True, inline="always")
def _least_future(child, lf, budget_lane, ranks, left, lo, hi, future):
    """The least f among the labels lo..hi-1 whose ranks (and moves left) are at least the
    child's, and whether there is one: the first such label, since a point's labels are in
    ascending order of f (``_by_future``)."""
    S = child.shape[0]
    for k in range(lo, hi):
        ok = budget_lane == 0 or left[k] >= lf
        j = 0
        while ok and j < S:
            ok = ranks[k, j] >= child[j]
            j += 1
        if ok:
            return future[k], True
    return np.inf, False


@njit(cache=True, nogil=True)
def _futures(t, T, ranks, acc, left, pos, nbr, up_rank, in_range_list, in_range_count, W, to_end, budget_lane,
             threshold, next_ranks, next_left, next_off, next_future, halt):
    """f of every kept S-label of slot t, from those of slot t+1 (module docstring)."""
    L, S = ranks.shape
    out = np.empty(L)
    child = np.empty(S, dtype=np.int64)
    slots_left = T - 2 - t  # moves that can still be made after slot t+1
    for l in range(L):
        if (l & 1023) == 0 and halt[0]:
            return out
        p = pos[l]
        best = -np.inf
        for o in range(-1, in_range_count[p]):
            for i in range(S):
                child[i] = ranks[l, i]
            if o >= 0:
                u = in_range_list[p, o]
                if up_rank[t, p, u] <= child[u]:
                    continue
                child[u] = up_rank[t, p, u]
            term = np.inf
            for i in range(S):
                if W[i, child[i], t + 1] < term:
                    term = W[i, child[i], t + 1]
            if t == T - 1:  # the last slot's upload: no move, no later slot
                best = max(best, term)
                continue
            for k in range(5):
                q = nbr[p, k]
                if q < 0:
                    continue
                lf = left[l] - (1 if q != p else 0)
                if lf < 0 or to_end[q] > min(lf, slots_left):
                    continue
                lf = min(lf, slots_left)
                f, found = _least_future(child, lf, budget_lane, next_ranks, next_left, next_off[q],
                                         next_off[q + 1], next_future)
                if not found:
                    f = threshold - (acc[l] + term)
                best = max(best, term + f)
        out[l] = best
    return out


@njit(cache=True, nogil=True)
def _tighten(ranks, acc, pos, left, ub, sensors, collapsed, budget_lane, s_ranks, s_left, s_off, s_future, halt):
    """min(ub, a + f) for each label of the whole network (module docstring)."""
    L = ranks.shape[0]
    S = sensors.shape[0]
    out = ub.copy()
    mine = np.empty(S, dtype=np.int64)
    for l in range(L):
        if (l & 1023) == 0 and halt[0]:
            return out
        whole = True
        for j in range(S):
            mine[j] = ranks[l, sensors[j]]
            if mine[j] == collapsed:
                whole = False
        if not whole:
            continue
        p = pos[l]
        f, found = _least_future(mine, left[l], budget_lane, s_ranks, s_left, s_off[p], s_off[p + 1], s_future)
        if not found:
            out[l] = -np.inf
        elif acc[l] + f < out[l]:
            out[l] = acc[l] + f
    return out
