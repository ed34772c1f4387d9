"""Fewest moves on the lattice around blocked points (MODEL.md sections 2 and 9).

Works on the (nx, ny) grid of lattice indices k * ny + l, so that validation (instance.py:
can the entity reach ``end``?) and the lattice (lattice.py) share one definition. Without
blocked points the fewest moves are the Manhattan distance; with them, a breadth-first search
(scipy's compiled graph search, linear in the lattice even for a maze of 10**6 points).
"""

from __future__ import annotations

import numpy as np

UNREACHABLE = 1 << 40  # the distance of a point that cannot be reached (sums of a few stay exact)
MOVES = np.array([(0, 0), (0, 1), (0, -1), (1, 0), (-1, 0)], dtype=np.int64)  # stay, N, S, E, W as (dk, dl)


def neighbors(nx: int, ny: int, blocked: np.ndarray) -> np.ndarray:
    """(nx * ny, 5) int64: the point after each of MOVES from each point, -1 where the move
    would leave the area or stand on a blocked point (and every move of a blocked point)."""
    out = np.empty((nx * ny, len(MOVES)), dtype=np.int64)
    nb = out.reshape(nx, ny, len(MOVES))
    for j, (dk, dl) in enumerate(MOVES.tolist()):  # (k, l) -> (k + dk) * ny + (l + dl)
        np.add(np.arange(nx, dtype=np.int64)[:, None] * ny + dk * ny + dl, np.arange(ny, dtype=np.int64)[None, :],
               out=nb[:, :, j])
        if dk:
            nb[nx - 1 if dk > 0 else 0, :, j] = -1
        if dl:
            nb[:, ny - 1 if dl > 0 else 0, j] = -1
    blocked = np.asarray(blocked, dtype=bool).reshape(-1)
    if blocked.any():  # a move into a blocked point is illegal like one off the area
        out[blocked] = -1
        out[blocked[np.maximum(out, 0)] & (out >= 0)] = -1
    return out


def free_graph(nx: int, ny: int, blocked: np.ndarray):
    """The sparse adjacency (CSR) of N/S/E/W moves between points that are not blocked."""
    from scipy.sparse import coo_matrix  # here: scipy costs a third of a second at start-up

    free = ~np.asarray(blocked, dtype=bool).reshape(nx, ny)
    ids = np.arange(nx * ny, dtype=np.int64).reshape(nx, ny)
    rows, cols = [], []
    for a, b in ((ids[:-1, :], ids[1:, :]), (ids[:, :-1], ids[:, 1:])):
        fa = free.reshape(-1)[a] & free.reshape(-1)[b]
        rows.append(a[fa])
        cols.append(b[fa])
    r, c = np.concatenate(rows), np.concatenate(cols)
    m = coo_matrix((np.ones(len(r), dtype=np.int8), (r, c)), shape=(nx * ny, nx * ny))
    return m.tocsr()


def steps(nx: int, ny: int, blocked: np.ndarray | None, sources, graph=None) -> np.ndarray:
    """(nx * ny,) int64: fewest moves from the nearest of ``sources`` (point indices) to every
    point, never standing on a blocked one; UNREACHABLE where there is no way (and on blocked
    points). ``graph`` is free_graph's result, reused across calls."""
    src = np.atleast_1d(np.asarray(sources, dtype=np.int64))
    if blocked is None or not np.any(blocked):  # Manhattan, one (nx, ny) array per source
        out = np.full((nx, ny), UNREACHABLE, dtype=np.int64)
        for s in src.tolist():
            a, b = divmod(s, ny)
            grid = np.abs(np.arange(nx, dtype=np.int64) - a)[:, None] + np.abs(np.arange(ny, dtype=np.int64) - b)[None, :]
            np.minimum(out, grid, out=out)
        return out.reshape(nx * ny)
    blocked = np.asarray(blocked, dtype=bool).reshape(-1)
    src = src[~blocked[src]]
    out = np.full(nx * ny, UNREACHABLE, dtype=np.int64)
    if not len(src):
        return out
    from scipy.sparse.csgraph import dijkstra  # only with blocked points (start-up, see free_graph)

    g = free_graph(nx, ny, blocked) if graph is None else graph
    d = dijkstra(g, directed=False, unweighted=True, indices=src, min_only=True)
    ok = np.isfinite(d)
    out[ok] = d[ok].astype(np.int64)
    out[blocked] = UNREACHABLE
    return out
