"""The Pareto filter of the label-setting programmes (_dp_core.pareto) against a plain one."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from voiopt.solvers.labels import kernels as core


def pack(lanes: np.ndarray) -> np.ndarray:
    """Lanes (m, L) of values < 2**15 packed four 16 bits to a word, as the kernels pack them."""
    m, L = lanes.shape
    key = np.zeros((m, (L + 3) // 4), dtype=np.uint64)
    for d in range(L):
        key[:, d // 4] |= lanes[:, d].astype(np.uint64) << np.uint64(16 * (d % 4))
    return key


def plain(lanes: np.ndarray, acc: np.ndarray) -> list[int]:
    """Candidates in order of value, then lane sum (both descending), then index; each kept
    unless one before it has every lane at least as high."""
    order = sorted(range(len(acc)), key=lambda c: (-acc[c], -int(lanes[c].sum()), c))
    ranked = lanes[order]
    return [c for j, c in enumerate(order) if not (ranked[:j] >= ranked[j]).all(axis=1).any()]


@settings(max_examples=200, deadline=None)
@given(st.data())
def test_the_filter_keeps_exactly_the_candidates_no_earlier_one_dominates(data):
    m = data.draw(st.integers(1, 200))  # with and without the grid (SMALL)
    L = data.draw(st.integers(1, 14))
    top = data.draw(st.sampled_from([1, 3, 12, 400, 32767]))  # few values: many ties and dominations
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    lanes = rng.integers(0, top + 1, size=(m, L))
    if data.draw(st.booleans()):
        lanes[:, rng.integers(0, L)] = rng.integers(0, 2)  # a lane with no spread
    acc = rng.integers(0, data.draw(st.integers(1, 6)), size=m).astype(float)  # ties in value too
    kept = np.empty(m, dtype=np.int64)
    nk = core.pareto(pack(lanes), -acc, -lanes.sum(axis=1).astype(float), m, L, kept, np.zeros(1, dtype=np.bool_))
    assert kept[:nk].tolist() == plain(lanes, acc)


def test_the_filter_gives_up_when_halted():
    lanes = np.arange(12).reshape(6, 2)
    kept = np.empty(6, dtype=np.int64)
    assert core.pareto(pack(lanes), np.zeros(6), -lanes.sum(axis=1).astype(float), 6, 2, kept,
                       np.ones(1, dtype=np.bool_)) == -1
