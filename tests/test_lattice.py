"""The lattice of MODEL.md section 2: points, moves that stay in the area, distances, ranges."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from voiopt.core.instance import from_dict
from voiopt.grid import lattice


def _inst(width=5, height=3, step=1.0, start=(0, 0), sensors=((1.5, 1.0),), d_th=1.0):
    return from_dict({
        "name": "lat", "area": {"width": width, "height": height}, "step": step, "horizon": 3,
        "start": list(start), "channel": {"d_th": d_th},
        "sensors": [{"position": list(p), "rho": 0.5} for p in sensors],
    })


def test_points_are_the_lattice_of_the_area():
    lat = lattice.build(_inst(width=5, height=3))
    assert (lat.nx, lat.ny, lat.n_points) == (6, 4, 24)  # 0..5 by 0..3
    assert lat.index(5, 3) == 23 and lat.index(2.5, 1) is None and lat.index(6, 0) is None
    np.testing.assert_array_equal(lat.points[lat.index(2, 1)], [2.0, 1.0])
    lat = lattice.build(_inst(width=5, height=3, step=2.0))  # 0, 2, 4 by 0, 2
    assert (lat.nx, lat.ny) == (3, 2) and lat.index(4, 2) is not None and lat.index(1, 0) is None


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 6), st.integers(1, 6), st.data())
def test_moves_are_one_step_and_never_leave_the_area(w, h, data):
    k = data.draw(st.integers(0, w))
    l_ = data.draw(st.integers(0, h))
    lat = lattice.build(_inst(width=w, height=h, start=(k, l_), sensors=((0.5, 0.5),)))
    for p in range(lat.n_points):
        targets = [q for q in lat.neighbors[p] if q >= 0]
        assert lat.neighbors[p, 0] == p  # staying is always a move
        for q in targets:
            assert np.abs(lat.coords[q] - lat.coords[p]).sum() <= 1
        # exactly the in-area points at Manhattan distance <= 1
        near = np.flatnonzero(np.abs(lat.coords - lat.coords[p]).sum(axis=1) <= 1)
        assert sorted(targets) == sorted(near.tolist())
    assert lat.start == lat.index(k, l_)
    assert (lat.reachable(0) == (np.arange(lat.n_points) == lat.start)).all()
    assert lat.reachable(w + h).all()


def test_distances_and_ranges_include_the_threshold():
    lat = lattice.build(_inst(sensors=((1.5, 1.0), (4.0, 3.0)), d_th=0.5))
    p = lat.index(1, 1)
    assert lat.distance[0, p] == pytest.approx(0.5) and lat.in_range[0, p]
    assert lat.distance[0, lat.index(2, 2)] == pytest.approx(math.hypot(0.5, 1.0))
    assert not lat.in_range[0, lat.index(2, 2)]
    assert lat.in_range[1].sum() == 1  # only the point it sits on is within 0.5
    assert lattice.unservable_sensors(_inst(sensors=((1.5, 1.5),), d_th=0.5)) == [0]
    assert lattice.unservable_sensors(_inst()) == []
