"""The simulator against a hand-checked trace and an independent recomputation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import voiopt
from voiopt.core.plan import Plan
from voiopt.core.simulate import check_plan, simulate
from voiopt.errors import PlanError
from voiopt.networks.generate import case_study_plan

CASE_STUDY_PLAN = case_study_plan().to_dict()

B = 2e6


def voi_by_hand(aoi, q, rho, power=1.0):
    pg, bn = power * 1e-5, B * 1e-14 * q * q
    return -B * math.log1p(-pg * rho**aoi / (bn + pg)) / math.log(2)


def test_case_study_hand_trace(case_study):
    traj = simulate(case_study, Plan.from_dict(CASE_STUDY_PLAN))
    # A(0) = [2, 4, 4]; uploads: s0 in slots 2-4, s1 in 5-6, s2 in 8-9 (effective next slot)
    expected_aoi = [
        [2, 4, 4], [3, 5, 5], [4, 6, 6], [1, 7, 7], [1, 8, 8], [1, 9, 9],
        [2, 1, 10], [3, 1, 11], [4, 2, 12], [5, 3, 1], [6, 4, 1],
    ]
    assert traj.aoi.tolist() == expected_aoi
    # effective distances: s0 uploads last at (2, 4) from (1.4, 3.6); s1 at (4, 4) from (3.7, 4.4);
    # s2 at (4, 1) from (4.3, 1.3)
    assert traj.distance[3, 0] == pytest.approx(math.sqrt(0.4**2 + 0.6**2))
    assert traj.distance[4, 0] == pytest.approx(math.sqrt(0.6**2 + 0.6**2))
    assert traj.distance[10].tolist() == pytest.approx([math.sqrt(0.52), 0.5, math.sqrt(0.18)])
    assert traj.distance[8, 2] == 1.0  # still the initial distance
    # the least VoI: sensor 2 in slot 8, age 12 at initial distance 1
    assert traj.metrics["min-voi"] == pytest.approx(voi_by_hand(12, 1.0, 0.5), rel=1e-12)
    assert traj.voi[8, 2] == traj.metrics["min-voi"]
    mins = [min(voi_by_hand(a, q, r) for a, q, r in zip(traj.aoi[t], traj.distance[t], (0.7, 0.6, 0.5), strict=True)) for t in range(1, 11)]
    assert traj.metrics["mean-min-voi"] == pytest.approx(sum(mins) / 10, rel=1e-12)
    assert traj.metrics["max-aoi"] == 12
    assert traj.metrics["mean-max-aoi"] == pytest.approx((5 + 6 + 7 + 8 + 9 + 10 + 11 + 12 + 5 + 6) / 10)


def independent(inst, positions, schedule):
    """Metrics recomputed in plain Python from MODEL.md sections 3-5."""
    aoi = [s.initial_aoi for s in inst.sensors]
    q = [inst.initial_distance(i) for i in range(inst.n_sensors)]
    mins, maxs = [], []
    for t in range(inst.horizon):
        u = schedule[t]
        x, y = positions[t]
        new_aoi = [a + 1 for a in aoi]
        if u is not None:
            sx, sy = inst.sensors[u].position
            new_aoi[u] = 1
            q[u] = math.hypot(x - sx, y - sy)
        aoi = new_aoi
        vs = [voi_by_hand(aoi[i], q[i], s.rho, s.power_w) if s.rho**aoi[i] > 1e-300 else 0.0 for i, s in enumerate(inst.sensors)]
        mins.append(min(vs))
        maxs.append(max(aoi))
    return {"min-voi": min(mins), "mean-min-voi": sum(mins) / len(mins), "max-aoi": max(maxs), "mean-max-aoi": sum(maxs) / len(maxs)}


@st.composite
def instance_and_plan(draw):
    n = draw(st.integers(1, 4))
    size = draw(st.sampled_from([1.0, 2.0, 3.0, 4.0]))
    inst = voiopt.generate(
        n, draw(st.integers(1, 25)), width=size, height=draw(st.sampled_from([1.0, 2.0, 3.0])),
        rho=(0.05, 0.95), power_w=draw(st.sampled_from([1.0, 0.01, 0.001])),
        initial_aoi=(1, 6), seed=draw(st.integers(0, 10_000)),
    )
    from voiopt.grid import lattice

    lat = lattice.build(inst)
    p, positions, schedule = lat.start, [], []
    for _ in range(inst.horizon):
        positions.append(lat.points[p].tolist())
        choices = [None] + [i for i in range(n) if lat.in_range[i, p]]
        schedule.append(draw(st.sampled_from(choices)))
        moves = [m for m in lat.neighbors[p] if m >= 0]
        p = int(draw(st.sampled_from(moves)))
    return inst, positions, schedule


@settings(max_examples=150, deadline=None)
@given(instance_and_plan())
def test_random_plans_match_independent_recomputation(case):
    inst, positions, schedule = case
    metrics = voiopt.evaluate(inst, {"positions": positions, "schedule": schedule})
    ref = independent(inst, positions, schedule)
    assert metrics["max-aoi"] == ref["max-aoi"]
    assert metrics["mean-max-aoi"] == pytest.approx(ref["mean-max-aoi"], rel=1e-12)
    for m in ("min-voi", "mean-min-voi"):
        assert metrics[m] == pytest.approx(ref[m], rel=1e-9, abs=1e-300)


def plan_with(**changes):
    d = {k: list(v) for k, v in CASE_STUDY_PLAN.items()}
    for key, (t, value) in changes.items():
        d[key][t] = value
    return d


ILLEGAL = [
    ({"positions": [[0, 2]] * 9, "schedule": [None] * 9}, "positions: must have horizon = 10 entries, got 9"),
    ({"positions": CASE_STUDY_PLAN["positions"], "schedule": [None] * 11}, "schedule: must have horizon = 10 entries, got 11"),
    (plan_with(positions=(0, [0, 1])), "positions[0]: must equal start"),
    (plan_with(positions=(3, [3, 3])), "positions[3]: [3, 3] is not one N/S/E/W step"),
    (plan_with(positions=(3, [2, 2])), "positions[3]: [2, 2] is not one N/S/E/W step"),  # diagonal
    (plan_with(positions=(1, [0.5, 2])), "positions[1]: [0.5, 2] is not a lattice point"),
    (plan_with(positions=(1, [-1, 2])), "positions[1]: [-1, 2] is outside the area"),
    (plan_with(schedule=(0, 2)), "schedule[0]: sensor 2 is out of range"),
    (plan_with(schedule=(2, 3)), "schedule[2]: unknown sensor index 3"),
    (plan_with(schedule=(2, -1)), "schedule[2]: unknown sensor index -1"),
    (plan_with(schedule=(2, [0, 1])), "schedule[2]: must be a sensor index or null"),  # two sensors in one slot
    (plan_with(schedule=(2, "0")), "schedule[2]: must be a sensor index or null"),
    ({"positions": CASE_STUDY_PLAN["positions"]}, "schedule: is required"),
    ({"positions": CASE_STUDY_PLAN["positions"], "schedule": [None] * 10, "moves": []}, "moves: unknown field"),
]


@pytest.mark.parametrize("plan,message", ILLEGAL)
def test_illegal_plans_are_rejected(case_study, plan, message):
    with pytest.raises(PlanError) as e:
        voiopt.evaluate(case_study, plan)
    assert str(e.value).startswith(message), str(e.value)


def test_whole_result_is_accepted_as_plan(case_study):
    result = {"instance": "case-study", "plan": CASE_STUDY_PLAN, "status": "feasible"}
    assert voiopt.evaluate(case_study, result) == voiopt.evaluate(case_study, CASE_STUDY_PLAN)


def test_sensor_out_of_every_range_only_decays():
    inst = voiopt.Instance.replace(
        voiopt.generate(1, 5, width=1, height=1, seed=1),
        channel={"d_th": 0.01},
        sensors=[{"position": [0.5, 0.5], "rho": 0.5, "initial_aoi": 3}],
    )
    traj = simulate(inst, Plan.from_dict({"positions": [list(inst.start)] * 5, "schedule": [None] * 5}))
    assert traj.aoi[:, 0].tolist() == [3, 4, 5, 6, 7, 8]
    assert np.all(np.diff(traj.voi[:, 0]) < 0)


@st.composite
def long_indices(draw):
    """A network and (K, T) point indices and schedule, T around the simulator's LONG; the
    walk and uploads random (the dynamics do not need them legal), distinct sensors per slot."""
    from voiopt.core.simulate import LONG
    from voiopt.grid import lattice

    n, K = draw(st.integers(1, 6)), draw(st.integers(1, 3))
    T = draw(st.sampled_from([1, 7, LONG - 1, LONG, LONG + 2500]))
    inst = voiopt.generate(n, T, rho=(0.05, 0.999), initial_aoi=(1, 9), seed=draw(st.integers(0, 10_000)))
    lat = lattice.build(inst)
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    idx = rng.integers(0, len(lat.points), size=(K, T))
    period = draw(st.sampled_from([1, 13, 50, T]))  # uploads in the first 40 slots of each period
    busy = draw(st.sampled_from([0.0, 0.3, 0.9]))
    sched = np.full((K, T), -1)
    for t in range(T):
        if t % period < 40 and rng.random() < busy:
            sensors = rng.permutation(np.arange(-1, n))[:K]  # distinct, or none
            sched[:len(sensors), t] = sensors
    ok = sched >= 0
    sched[ok & ~lat.in_range[np.where(ok, sched, 0), idx]] = -1  # uploads only in range
    return inst, idx, sched


@settings(max_examples=40, deadline=None)
@given(long_indices())
def test_the_closed_form_dynamics_and_distinct_pairs_change_no_bit(case):
    """simulate_indices computes every slot at once and values each sensor's distinct (age,
    distance) pairs once from LONG slots on (4 s at T = 3 x 10^5 before, most of it libm): the
    ages, distances and VoI must be those of ``advance`` applied slot by slot and of
    physics.voi on every entry, bit for bit."""
    _same_as_slot_by_slot(*case)


@pytest.mark.parametrize("robots", [1, 3])
@pytest.mark.parametrize("method", ["shortest-path", "idle"])
def test_a_long_tour_is_valued_bit_for_bit_as_slot_by_slot(method, robots):
    """The same on the plans of a tour (which repeat their ages) at T = 6000, and on a plan
    without uploads (every sensor aged A(0) + t)."""
    inst = voiopt.generate(5, 6000, seed=11, robots=robots)
    if method == "idle":
        r = voiopt.solve(inst, "shortest-path")
        idx, sched = check_plan(inst, r.plan)
        idx, sched = np.repeat(np.atleast_2d(idx)[:, :1], 6000, axis=1), np.full((robots, 6000), -1)
    else:
        idx, sched = check_plan(inst, voiopt.solve(inst, method).plan)
    _same_as_slot_by_slot(inst, np.atleast_2d(idx), np.atleast_2d(sched))


def _same_as_slot_by_slot(inst, idx, sched):
    """Both ways of valuing: libm from a compiled loop (every entry, where the arrays are large
    enough; physics.compiled) and through Python's math (each distinct pair once from LONG slots
    on), against slot by slot with Python's math."""
    from unittest import mock

    from voiopt.core import physics
    from voiopt.core.simulate import simulate_indices, slot_by_slot

    with mock.patch.object(physics, "compiled", lambda size: False):
        aoi, dist, v = slot_by_slot(inst, idx, sched)
    for compiled in (physics.compiled, lambda size: False):
        with mock.patch.object(physics, "compiled", compiled):
            traj = simulate_indices(inst, idx if len(idx) > 1 else idx[0], sched if len(sched) > 1 else sched[0])
        assert np.array_equal(traj.aoi, aoi) and traj.aoi.dtype == aoi.dtype
        assert np.array_equal(traj.distance, dist)
        assert np.array_equal(traj.voi.view(np.int64), v.view(np.int64))  # the bits, nan and -0.0 included


def test_a_long_plan_is_checked_at_once_and_its_first_fault_named():
    """check_plan maps each distinct position once and checks the schedule on all slots at once
    (T = 10^6: 0.9 s for the positions alone as a loop over the slots); a plan with faults
    still gets the message of its first one, and a plan built in Python with numpy integers
    or lists for pairs is valued as its JSON form is."""
    inst = voiopt.generate(3, 3000, seed=2)
    good = voiopt.solve(inst, "shortest-path").plan.to_dict()
    want = voiopt.evaluate(inst, good)

    def fault(**changes):
        d = {k: list(v) for k, v in good.items()}
        for key, pairs in changes.items():
            for t, value in pairs:
                d[key][t] = value
        with pytest.raises(PlanError) as e:
            voiopt.evaluate(inst, d)
        return str(e.value)

    assert fault(positions=[(2500, [0.5, 0]), (2000, [0.5, 0])]).startswith("positions[2000]: [0.5, 0] is not a lattice point")
    assert fault(positions=[(2200, [-3, 0])]).startswith("positions[2200]: [-3, 0] is outside the area")
    ups = [t for t, u in enumerate(good["schedule"]) if u is not None]
    assert fault(schedule=[(ups[-1], -1), (ups[-2], 7)]).startswith(f"schedule[{ups[-2]}]: unknown sensor index 7")
    assert fault(schedule=[(ups[-1], -1)]).startswith(f"schedule[{ups[-1]}]: unknown sensor index -1")
    from voiopt.grid import lattice

    lat = lattice.build(inst)
    far = [t for t, xy in enumerate(good["positions"]) if not lat.in_range[0, lat.index(*xy)]]
    assert fault(schedule=[(far[-1], 0), (far[-2], 0)]).startswith(f"schedule[{far[-2]}]: sensor 0 is out of range")
    plan = Plan(tuple(map(list, good["positions"])), tuple(None if u is None else np.int64(u) for u in good["schedule"]))
    assert voiopt.evaluate(inst, plan) == want
    flags = Plan(plan.positions, tuple(True if u is not None else None for u in good["schedule"]))
    with pytest.raises(PlanError, match=rf"^schedule\[{ups[0]}\]: must be a sensor index or null, got True"):
        voiopt.evaluate(inst, flags)


COORDS = st.one_of(st.integers(-3, 8), st.floats(-1e3, 1e3), st.sampled_from([True, 2**1100, float("nan"), -0.0, "1", None]))


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(st.lists(COORDS, min_size=2, max_size=2), st.lists(COORDS, max_size=3), st.just((1, 2))),
                max_size=12),
       st.lists(st.one_of(st.none(), st.integers(-2, 12), st.sampled_from([1.0, 2.5, True, 10**6, "0", [0]])),
                max_size=12))
def test_a_plans_file_is_read_the_same_at_c_speed_and_slot_by_slot(positions, schedule):
    """Plan.from_dict reads the usual file (pairs of numbers, sensor indices or nulls) at C
    speed (T = 10^6: 4.5 s slot by slot); anything else goes slot by slot. Both ways give the
    same plan, or the same error."""
    from unittest import mock

    from voiopt.core import plan as plan_mod

    def read():
        try:
            return Plan.from_dict({"positions": positions, "schedule": schedule})
        except PlanError as e:
            return str(e)

    fast = read()
    with mock.patch.object(plan_mod, "_fast", lambda *a: None):
        slow = read()
    assert fast == slow
    if isinstance(fast, Plan):
        assert all(type(c) is float for xy in fast.positions for c in xy)
        assert all(u is None or type(u) is int for u in fast.schedule)


def test_after_review_odd_plans_built_in_python_fail_as_before():
    """A huge int among the positions names the first bad slot (it raised OverflowError);
    Plan's conversions refuse what they cannot hold instead of truncating it."""
    from voiopt.core import instance as im

    inst = im.from_dict({"name": "r", "area": {"width": 2, "height": 2}, "horizon": 3, "start": [0, 0],
                         "sensors": [{"position": [1, 1], "rho": 0.5}]})
    with pytest.raises(PlanError, match=r"^positions\[1\]: \[0, 3\] is outside the area"):
        check_plan(inst, Plan(((0, 0), (0, 3), (0, 10**400)), (None,) * 3))
    with pytest.raises(TypeError, match="must be integers"):
        Plan.from_indices(inst, np.array([0.0, 1.5, 1.0]), np.array([-1, -1, -1]))
    with pytest.raises(TypeError, match="must be integers"):
        Plan.from_indices(inst, np.array([0, 1, 1]), np.array([-0.5, -1, -1]))
    with pytest.raises(ValueError):
        Plan(((0, 0, 0),) * 3, (None,) * 3).to_dict()
    big = Plan.from_indices(inst, np.array([0, 1, 1], dtype=np.uint64), np.array([2**63, 0, 2**64 - 1], dtype=np.uint64))
    assert big.schedule == (2**63, 0, 2**64 - 1)  # as given: check_plan names them unknown sensors


def test_a_sensor_just_beyond_d_th_is_named_with_the_digits_that_show_it():
    """A sensor 1e-7 m beyond d_th was refused with "distance 1 > d_th 1" (an independent
    oracle, 2026-12-03); the distance is shown whole when four digits would hide the excess."""
    for x, d_th, shown in [(1.0000001, 1.0, "distance 1.0000001 > d_th 1.0"),
                           (1.00005, 1.00004, "distance 1.00005 > d_th 1.00004"),  # a review: "distance 1 > d_th 1.00004"
                           (1.0, 0.99999, "distance 1 > d_th 0.99999"),
                           (1.5, 1.0, "distance 1.5 > d_th 1)")]:
        inst = voiopt.core.instance.from_dict({"area": {"width": 2, "height": 1}, "horizon": 1, "start": [0, 0],
                                          "channel": {"d_th": d_th}, "sensors": [{"position": [x, 0], "rho": 0.5}]})
        with pytest.raises(PlanError) as e:
            voiopt.evaluate(inst, {"positions": [[0, 0]], "schedule": [0]})
        assert str(e.value).startswith("schedule[0]: sensor 0 is out of range at positions[0] (") and shown in str(e.value)
