"""Whether the robots of a fleet can keep every rule together (MODEL.md sections 9 and 10).

Each robot alone may reach its ``end`` within its ``max_moves`` and still the fleet have no
legal plan: two robots in a corridor cannot pass each other. ``table`` fills, backwards over
the slots, which joint points (and moves made, where a budget binds) can still reach the last
slot keeping every rule: no shared point, no swap, no blocked point, every end and budget. It
is exact. It stores only the slots after the last one equal to its successor (every earlier
slot is the same), but may need every slot: up to the joint points times the slots (times the
budgets' digits). So validation (instance.py rejects a fleet with no joint plan) and the
baselines' exact paths use it only up to CELLS such entries; the fleet's MDP
(models/fleet_mdp.py) at any size, watched by the memory limit.
"""

from __future__ import annotations

import collections
import functools
import itertools
from dataclasses import dataclass

import numpy as np

from voiopt.errors import OptionError
from voiopt.grid import paths
from voiopt.runtime import numba_start
from voiopt.runtime.jit import njit
from voiopt.runtime.stop import halt_if_asked

CELLS = 5 * 10**6  # the most joint points x slots (or x joint moves) tabulated by legal_paths (about 1 s)
WORK = 6 * 10**8  # the most entries x joint moves validation tabulates (about 1 s: up to 5**K moves tried per entry)


class NoJointPlan(OptionError):
    """No legal joint plan: ``proved`` when a search covered every joint move (the fleet has
    none, and the methods report status ``infeasible``), else the search gave up (a legal plan
    may still exist)."""

    def __init__(self, message: str, proved: bool = True) -> None:
        super().__init__(message)
        self.proved = proved


@dataclass(frozen=True, eq=False)
class Table:
    alive: np.ndarray  # (T - first, n**K, M) uint8: alive[row(t), config, moves made]
    first: int  # the slots before it are as slot ``first``: only slots first .. T-1 are stored
    configs: np.ndarray  # (n**K, K) the robots' points of each joint point, robot 0 most significant
    nxt_cfg: np.ndarray  # (n**K, 5**K) the joint point after each joint move, -1 where illegal
    moved: np.ndarray  # (n**K, 5**K, K) whether each robot moves
    mv_idx: np.ndarray  # (M, K) each robot's moves made, by moves-made index
    strides: np.ndarray  # (K,) the strides of the moves-made index
    counted: np.ndarray  # (K,) bool: the robot's budget binds (its moves made are counted)
    budgets: np.ndarray  # (K,) each robot's min(max_moves, T - 1)
    n_points: int

    def row(self, t: int) -> np.ndarray:
        """alive in slot t: (n**K, M)."""
        return self.alive[max(t - self.first, 0)]


def budgets(max_moves, horizon: int) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """Each robot's move budget min(max_moves, T - 1), whether it binds, and the radix of its
    moves-made digit (budget + 2: one past the budget marks "over")."""
    b = np.array([horizon - 1 if m is None else min(int(m), horizon - 1) for m in max_moves], dtype=np.int64)
    counted = b < horizon - 1
    return b, counted, [int(x) + 2 if c else 1 for x, c in zip(b, counted, strict=True)]


def entries(n_points: int, n_robots: int, horizon: int, radix) -> float:
    """The entries of the alive table: slots x joint points x moves made (``budgets``' radix)."""
    return horizon * float(n_points) ** n_robots * float(np.prod(radix))


def cells(n_points: int, n_robots: int, horizon: int, radix) -> float:
    """What ``table`` tabulates: the alive table's entries, or the joint moves if more."""
    return max(entries(n_points, n_robots, horizon, radix), float(n_points) ** n_robots * 5.0**n_robots)


@njit(cache=True)
def _digits(C, base, K):
    """(C, K) the base-``base`` digits of 0..C-1, most significant first: each robot's point of
    a joint point (base n), or each robot's move of a joint move (base 5)."""
    out = np.empty((C, K), np.int64)
    for c in range(C):
        x = c
        for k in range(K - 1, -1, -1):
            out[c, k] = x % base
            x //= base
    return out


@njit(cache=True)
def _joint_moves(neighbors, configs, digit, nxt_cfg, moved, c_lo, c_hi):
    """Fill nxt_cfg[c_lo:c_hi] and moved[c_lo:c_hi]: for every joint move (5**K, robot 0's move
    most significant) from each joint point (robot 0's point most significant), the next joint
    point, -1 where a move leaves the area or hits a blocked point, or two robots share or swap
    points, and whether each robot moves."""
    n, K = neighbors.shape[0], configs.shape[1]
    nxt = np.empty(K, np.int64)
    for c in range(c_lo, c_hi):
        for mv in range(digit.shape[0]):
            ok = True
            for k in range(K):
                nxt[k] = neighbors[configs[c, k], digit[mv, k]]
                moved[c, mv, k] = nxt[k] != configs[c, k]
                ok = ok and nxt[k] >= 0
            for k in range(1, K):
                for j in range(k):
                    if configs[c, k] == configs[c, j] or nxt[k] == nxt[j] or (
                            nxt[k] == configs[c, j] and nxt[j] == configs[c, k]):
                        ok = False
            idx = -1
            if ok:
                idx = 0
                for k in range(K):
                    idx = idx * n + nxt[k]
            nxt_cfg[c, mv] = idx


@njit(cache=True, inline="always")
def _next_alive(alive_next, c, m, nxt_cfg, moved, counted, budgets, strides, mv_idx):
    """The first joint move from joint point ``c`` with moves made ``m`` that leads to a joint
    point and moves made alive in the next slot (``alive_next``: (n**K, M)), no counted robot
    passing its budget: (next joint point, next moves made), or (-1, -1) if none does."""
    K = counted.shape[0]
    for mv in range(nxt_cfg.shape[1]):
        c2 = nxt_cfg[c, mv]
        if c2 < 0:
            continue
        m2, good = m, True
        for k in range(K):
            if counted[k] and moved[c, mv, k]:
                if mv_idx[m, k] + 1 > budgets[k]:
                    good = False
                m2 += strides[k]
        if good and alive_next[c2, m2]:
            return c2, m2
    return -1, -1


@njit(cache=True)
def _alive_slot(here, alive_next, c_lo, c_hi, within, nxt_cfg, moved, counted, budgets, strides, mv_idx):
    """Fill here[c_lo:c_hi] (a slot's (n**K, M), zeros) from the next slot's: the moves made
    are ``within`` every budget, and some joint move leads to a joint point and moves made that
    are alive in the next slot (``_next_alive``). Returns whether those rows equal the next
    slot's."""
    same = True
    for c in range(c_lo, c_hi):
        for m in range(here.shape[1]):
            if within[m] and _next_alive(alive_next, c, m, nxt_cfg, moved, counted, budgets, strides, mv_idx)[0] >= 0:
                here[c, m] = 1
            same = same and here[c, m] == alive_next[c, m]
    return same


CHUNK = 4096  # joint points per kernel call: the stop rule is checked between calls
CHUNK_WORK = 2 * 10**7  # at most about this many (moves made x joint moves) per call (about 0.05 s)


def _alive_backwards(last, within, nxt_cfg, moved, counted, budgets, strides, mv_idx, horizon, stop=None,
                     held=0.0) -> tuple[np.ndarray, int]:
    """(alive, first): the slots first .. T-1 of the table, from the last slot's ``last``
    backwards, CHUNK joint points at a time, checking ``stop`` (voiopt.runtime.stop.Stopped; the
    memory limit counts the slots stored and ``held`` bytes) between them: two robots on a
    21 x 21 factory floor with ends took 8 s, past any time limit.

    The step from one slot to the one before does not depend on the slot. So once a slot equals
    the next one, every earlier slot equals it too, and is not stored: three robots with budgets
    at T = 589 once filled 3.2 GB with copies of one slot."""
    rows = [last]  # slots T-1, T-2, ... down to the first stored one
    chunk = max(1, min(CHUNK, CHUNK_WORK // (last.shape[1] * nxt_cfg.shape[1])))  # two robots with budgets of 80 on
    for _ in range(horizon - 1):  # a factory floor: 4096 joint points took seconds, past any stop
        here = np.zeros(last.shape, last.dtype)  # not zeros_like, which writes every byte
        same = True
        for lo in range(0, here.shape[0], chunk):
            halt_if_asked(stop, held + (len(rows) + 1) * last.nbytes)
            same &= _alive_slot(here, rows[-1], lo, min(here.shape[0], lo + chunk), within, nxt_cfg, moved, counted,
                                budgets, strides, mv_idx)
        if same:
            break
        rows.append(here)
    alive = np.empty((len(rows), *last.shape), dtype=last.dtype)
    for i in range(len(rows)):
        alive[len(rows) - 1 - i] = rows[i]
        rows[i] = None  # each slot freed as it is placed: the peak is one table, not two
    return alive, horizon - len(alive)


_MOVES: collections.OrderedDict = collections.OrderedDict()  # the last two lattices' joint moves


def _moves_of(neighbors: bytes, n: int, K: int, stop=None):
    """(configs, next config, moved) of every joint move from every joint point of a lattice's
    neighbours (as bytes), kept for the next table on the same lattice (the generator tries
    many ends on one lattice). Computed CHUNK joint points at a time, checking ``stop``
    between them (voiopt.runtime.stop.Stopped): 1.6 s for four robots, past a 0.5 s limit."""
    key = (neighbors, n, K)
    if key in _MOVES:
        _MOVES.move_to_end(key)
        return _MOVES[key]
    numba_start.start()
    nb = np.frombuffer(neighbors, dtype=np.int64).reshape(n, 5)
    configs, digit = _digits(n**K, n, K), _digits(5**K, 5, K)
    nxt_cfg = np.empty((n**K, 5**K), np.int64)  # written chunk by chunk: np.full took 1.2 to 2.8 s, unchecked
    moved = np.empty((n**K, 5**K, K), np.bool_)
    for lo in range(0, n**K, CHUNK):
        halt_if_asked(stop)
        _joint_moves(nb, configs, digit, nxt_cfg, moved, lo, min(n**K, lo + CHUNK))
    _MOVES[key] = (configs, nxt_cfg, moved)
    if len(_MOVES) > 2:
        _MOVES.popitem(last=False)
    return _MOVES[key]


def table(neighbors: np.ndarray, ends, max_moves, horizon: int, stop=None) -> Table:
    """The alive table of K robots on one lattice (``paths.neighbors``), each with its end
    (point index, or -1 for none) and max_moves (or None); Stopped if ``stop`` says stop first."""
    K, T = len(ends), horizon
    bud, counted, radix = budgets(max_moves, T)
    configs, nxt_cfg, moved = _moves_of(neighbors.tobytes(), neighbors.shape[0], K, stop)
    M = int(np.prod(radix))
    mv_idx = np.array(list(itertools.product(*[range(r) for r in radix])), dtype=np.int64).reshape(M, K)
    within = np.all(mv_idx <= np.where(counted, bud, np.iinfo(np.int64).max), axis=1)
    at_end = np.ones(len(configs), dtype=bool)
    for k, end in enumerate(ends):
        if end >= 0:
            at_end &= configs[:, k] == end
    halt_if_asked(stop)
    last = np.zeros((len(configs), M), np.uint8)  # pages the OS zeroes when first touched: two robots on a
    last[at_end] = within  # factory floor have 1.3 GB of it, and building it whole took 1.6 s, unchecked
    strides = np.cumprod([1, *radix[::-1]])[:-1][::-1].astype(np.int64)
    held = float(configs.nbytes + nxt_cfg.nbytes + moved.nbytes)
    alive, first = _alive_backwards(last, within, nxt_cfg, moved, counted, bud, strides, mv_idx, T, stop, held)
    return Table(alive, first, configs, nxt_cfg, moved, mv_idx, strides, counted, bud, neighbors.shape[0])


def number(digits, base: int) -> int:
    """The number whose digits in ``base`` are ``digits``, the first most significant: a joint
    point of the robots' points, or a joint action of their actions."""
    c = 0
    for d in digits:
        c = c * base + int(d)
    return c


def start_index(starts, n_points: int) -> int:
    """The joint point of the robots' points (robot 0 most significant)."""
    return number(starts, n_points)


def walk(tab: Table, starts) -> np.ndarray | None:
    """(K, T) points of a legal joint plan from the starts, the first alive joint move in each
    slot; None if the starts are not alive (no legal plan exists)."""
    c, m = start_index(starts, tab.n_points), 0
    if not tab.row(0)[c, m]:
        return None
    path = [c]
    for t in range(tab.first + len(tab.alive) - 1):  # alive in slot t: some move stays alive
        c, m = _next_alive(tab.row(t + 1), c, m, tab.nxt_cfg, tab.moved, tab.counted, tab.budgets, tab.strides,
                           tab.mv_idx)
        path.append(c)
    return tab.configs[path].T.copy()


def decides(n_points: int, n_robots: int, horizon: int, max_moves) -> bool:
    """Whether validation builds the table (``possible``): at most CELLS entries, and WORK
    entries times joint moves."""
    radix = budgets(max_moves, horizon)[2]
    return (cells(n_points, n_robots, horizon, radix) <= CELLS
            and entries(n_points, n_robots, horizon, radix) * 5.0**n_robots <= WORK)


@functools.lru_cache(maxsize=32)
def possible(nx: int, ny: int, blocked: tuple[int, ...], starts: tuple[int, ...], ends: tuple[int, ...],
             max_moves: tuple[int | None, ...], horizon: int) -> bool | None:
    """Whether some legal joint plan exists (validation's question; points are lattice indices,
    ends -1 for none), or None where the table would pass CELLS entries or WORK entries times
    joint moves. Without ends every robot may stay where it starts: True. Cached: a fleet
    loaded again is not tabulated again."""
    if all(e < 0 for e in ends):
        return True
    if not decides(nx * ny, len(starts), horizon, max_moves):
        return None
    mask = np.zeros(nx * ny, dtype=bool)
    mask[list(blocked)] = True
    tab = table(paths.neighbors(nx, ny, mask), ends, max_moves, horizon)
    return bool(tab.row(0)[start_index(starts, nx * ny), 0])


def pairs_possible(nx: int, ny: int, blocked: tuple[int, ...], starts: tuple[int, ...], ends: tuple[int, ...],
                   max_moves: tuple[int | None, ...], horizon: int) -> bool | None:
    """A fleet too large for ``possible``, asked two robots at a time: False when some pair has
    no legal joint plan (a proof: the others only add rules), else None (undecided). Only pairs
    ``decides`` admits are tabulated, and at most CELLS entries over all of them."""
    spent = 0.0
    for i, j in itertools.combinations(range(len(starts)), 2):
        if ends[i] < 0 and ends[j] < 0:
            continue
        pair_moves = (max_moves[i], max_moves[j])
        radix = budgets(pair_moves, horizon)[2]
        spent += cells(nx * ny, 2, horizon, radix)
        if spent > CELLS or not decides(nx * ny, 2, horizon, pair_moves):
            return None
        if possible(nx, ny, blocked, (starts[i], starts[j]), (ends[i], ends[j]), pair_moves, horizon) is False:
            return False
    return None
