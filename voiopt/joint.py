"""Whether the robots of a fleet can keep every rule together (MODEL.md sections 9 and 10).

Each robot alone may reach its ``end`` within its ``max_moves`` and still the fleet have no
legal plan: two robots in a corridor cannot pass each other. ``table`` fills, backwards over
the slots, which joint points (and moves made, where a budget binds) can still reach the last
slot keeping every rule: no shared point, no swap, no blocked point, every end and budget. It
is exact, and its size is the joint points times the slots (times the budgets' digits), so it
is used only up to CELLS entries: by validation (instance.py rejects a fleet with no joint
plan) and by the fleet's MDP and baselines (models/fleet_mdp.py).
"""

from __future__ import annotations

import collections
import functools
import itertools
from dataclasses import dataclass

import numpy as np

from voiopt import _grid, _numba_start
from voiopt._jit import njit
from voiopt.errors import OptionError
from voiopt.stop import halt_if_asked

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
    alive: np.ndarray  # (T, n**K, M) uint8: alive[t, config, moves made]
    configs: np.ndarray  # (n**K, K) the robots' points of each joint point, robot 0 most significant
    nxt_cfg: np.ndarray  # (n**K, 5**K) the joint point after each joint move, -1 where illegal
    moved: np.ndarray  # (n**K, 5**K, K) whether each robot moves
    mv_idx: np.ndarray  # (M, K) each robot's moves made, by moves-made index
    strides: np.ndarray  # (K,) the strides of the moves-made index
    counted: np.ndarray  # (K,) bool: the robot's budget binds (its moves made are counted)
    budgets: np.ndarray  # (K,) each robot's min(max_moves, T - 1)
    n_points: int


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
def _next_alive(alive, t, c, m, nxt_cfg, moved, counted, budgets, strides, mv_idx):
    """The first joint move from joint point ``c`` with moves made ``m`` in slot t that leads
    to a joint point and moves made alive in slot t + 1, no counted robot passing its budget:
    (next joint point, next moves made), or (-1, -1) if none does."""
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
        if good and alive[t + 1, c2, m2]:
            return c2, m2
    return -1, -1


@njit(cache=True)
def _alive_slot(alive, t, c_lo, c_hi, within, nxt_cfg, moved, counted, budgets, strides, mv_idx):
    """Fill alive[t, c_lo:c_hi] from alive[t + 1]: the moves made are ``within`` every budget,
    and some joint move leads to a joint point and moves made that are alive in the next slot
    (``_next_alive``). Returns whether those rows equal the next slot's."""
    same = True
    for c in range(c_lo, c_hi):
        for m in range(alive.shape[2]):
            if within[m] and _next_alive(alive, t, c, m, nxt_cfg, moved, counted, budgets, strides, mv_idx)[0] >= 0:
                alive[t, c, m] = 1
            same = same and alive[t, c, m] == alive[t + 1, c, m]
    return same


CHUNK = 4096  # joint points per kernel call: the stop rule is checked between calls
COPY_BYTES = 1 << 26  # bytes of the alive table copied between checks of the stop rule


def _alive_backwards(alive, within, nxt_cfg, moved, counted, budgets, strides, mv_idx, stop=None) -> None:
    """Fill alive[t] for t = T-2 .. 0 from alive[t + 1], CHUNK joint points at a time, checking
    ``stop`` (voiopt.stop.Stop) between them (voiopt.stop.Stopped): two robots on a 21 x 21 factory floor
    with ends took 8 s, past any time limit. The step from one slot to the one before does not
    depend on the slot, so once a slot equals the next one, every earlier slot equals it too:
    they are copied, not computed (a long horizon costs little)."""
    T, C, _ = alive.shape
    for t in range(T - 2, -1, -1):
        same = True
        for lo in range(0, C, CHUNK):
            halt_if_asked(stop)
            same &= _alive_slot(alive, t, lo, min(C, lo + CHUNK), within, nxt_cfg, moved, counted, budgets,
                                strides, mv_idx)
        if same:  # copied a block of slots at a time, the stop rule checked between blocks (3.2 GB took 6.9 s)
            step = max(1, COPY_BYTES // max(1, alive[t].nbytes))
            for lo in range(0, t, step):
                halt_if_asked(stop)
                alive[lo:min(t, lo + step)] = alive[t]
            return


_MOVES: collections.OrderedDict = collections.OrderedDict()  # the last two lattices' joint moves


def _moves_of(neighbors: bytes, n: int, K: int, stop=None):
    """(configs, next config, moved) of every joint move from every joint point of a lattice's
    neighbours (as bytes), kept for the next table on the same lattice (the generator tries
    many ends on one lattice). Computed CHUNK joint points at a time, checking ``stop``
    between them (voiopt.stop.Stopped): 1.6 s for four robots, past a 0.5 s limit."""
    key = (neighbors, n, K)
    if key in _MOVES:
        _MOVES.move_to_end(key)
        return _MOVES[key]
    _numba_start.start()
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
    """The alive table of K robots on one lattice (``_grid.neighbors``), each with its end
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
    alive = np.zeros((T, len(configs), M), dtype=np.uint8)
    alive[T - 1] = at_end[:, None] & within[None, :]
    strides = np.cumprod([1, *radix[::-1]])[:-1][::-1].astype(np.int64)
    _alive_backwards(alive, within, nxt_cfg, moved, counted, bud, strides, mv_idx, stop)
    return Table(alive, configs, nxt_cfg, moved, mv_idx, strides, counted, bud, neighbors.shape[0])


def start_index(starts, n_points: int) -> int:
    """The joint point of the robots' points (robot 0 most significant)."""
    c = 0
    for p in starts:
        c = c * n_points + int(p)
    return c


def walk(tab: Table, starts) -> np.ndarray | None:
    """(K, T) points of a legal joint plan from the starts, the first alive joint move in each
    slot; None if the starts are not alive (no legal plan exists)."""
    c, m = start_index(starts, tab.n_points), 0
    if not tab.alive[0, c, m]:
        return None
    path = [c]
    for t in range(tab.alive.shape[0] - 1):  # alive in slot t: some move stays alive
        c, m = _next_alive(tab.alive, t, c, m, tab.nxt_cfg, tab.moved, tab.counted, tab.budgets, tab.strides,
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
    tab = table(_grid.neighbors(nx, ny, mask), ends, max_moves, horizon)
    return bool(tab.alive[0, start_index(starts, nx * ny), 0])
