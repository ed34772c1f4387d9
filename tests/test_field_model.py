"""The field model of MODEL.md section 9 (blocked points, an end point, a move budget) in the
core: validation, the lattice's moves and distances, and the simulator, each checked against
the independent oracle of tests/oracles/model_oracle.py."""

from __future__ import annotations

import copy
import random

import numpy as np
import pytest
from conftest import field_instances, fleet_instances, tiny_instances
from oracles import model_oracle as oracle

import voiopt
from voiopt.core.instance import from_dict
from voiopt.errors import InstanceError, PlanError
from voiopt.grid import lattice

CASES = field_instances()


def _detour(T, **extra):
    """3 x 2 lattice, (1, 0) blocked: from (0, 0) to (2, 0) takes 4 moves around it."""
    d = {"area": {"width": 2, "height": 1}, "horizon": T, "start": [0, 0], "end": [2, 0], "blocked": [[1, 0]],
         "channel": {"d_th": 0.5}, "sensors": [{"position": [1, 1], "rho": 0.5}]}
    d.update(extra)
    return d


def test_cases_bind_each_field():
    """The shared cases (conftest.field_instances) are worth testing on: dropping a field
    changes some optimum in at least four cases for each field (by the oracle)."""
    assert len(CASES) >= 20
    binds = dict.fromkeys(("blocked", "end", "max_moves"), 0)
    for inst in CASES:
        if min(binds.values()) >= 4:
            break
        d = inst.to_dict()
        for field in binds:
            if field in d and binds[field] < 4:
                free = {k: v for k, v in d.items() if k != field}
                a, b = _optima(d), _optima(free)
                binds[field] += any(a[ob] != pytest.approx(b[ob], rel=1e-9) for ob in oracle.OBJECTIVES)
    assert min(binds.values()) >= 4, binds


def _optima(d):
    """The oracle's optimum of every objective, from one enumeration of the legal plans."""
    best = {}
    for plan in oracle.legal_plans(d):
        for ob, v in oracle.simulate(d, plan).items():
            if ob in best:
                best[ob] = max(best[ob], v) if oracle.OBJECTIVES[ob] else min(best[ob], v)
            else:
                best[ob] = v
    return best


@pytest.mark.parametrize("T, ok", [(4, False), (5, True)])
def test_end_must_be_reachable_around_blocked_points(T, ok):
    d = _detour(T)
    if ok:
        assert from_dict(d).end == (2.0, 0.0)
        oracle.check_instance(d)
        return
    with pytest.raises(InstanceError, match=r"^end: \[2, 0\] is not reachable within 3 moves \(horizon 4 allows 3\)"
                                            r": it is 4 moves from start \[0, 0\] around the blocked points$"):
        from_dict(d)
    with pytest.raises(oracle.OracleError):
        oracle.check_instance(d)


@pytest.mark.parametrize("change, message", [
    (dict(max_moves=3), r"^end: \[2, 0\] is not reachable within 3 moves \(max_moves is 3\)"),
    (dict(blocked=[[1, 0], [1, 1]]), r"^end: \[2, 0\] is not reachable from start \[0, 0\]: the blocked points wall"),
    (dict(blocked=[[0, 0]]), r"^blocked\[0\]: \[0, 0\] is the start point, which must stay free$"),
    (dict(blocked=[[2, 0]]), r"^blocked\[0\]: \[2, 0\] is the end point, which must stay free$"),
    (dict(blocked=[[1, 0], [1, 0.0]]), r"^blocked\[1\]: \[1, 0\] is listed twice \(also blocked\[0\]\)$"),
    (dict(blocked=[[0.5, 0]]), r"^blocked\[0\]: must be a lattice point"),
    (dict(blocked=[[3, 0]]), r"^blocked\[0\]: must lie in the area"),
    (dict(blocked=[1, 0]), r"^blocked\[0\]: must be a pair \[x, y\], got 1 \(and 1 more\)$"),
    (dict(blocked="none"), r"^blocked: must be a list of lattice points"),
    (dict(blocked=[[x, y] for x in range(3) for y in range(2)]), r"^blocked: must leave some of the 6 lattice points"),
    (dict(end=[5, 0]), r"^end: must lie in the area"),
    (dict(end=None), r"^end: must be a pair"),
    (dict(max_moves=-1), r"^max_moves: must be an integer >= 0, got -1$"),
    (dict(max_moves=1.5), r"^max_moves: must be an integer, got 1.5$"),
    (dict(max_moves=True), r"^max_moves: must be an integer, got true$"),
])
def test_bad_field_values_name_the_field_and_value(change, message):
    d = _detour(6, **change)
    with pytest.raises(InstanceError, match=message):
        from_dict(d)
    with pytest.raises(oracle.OracleError):
        oracle.check_instance(d)


def test_fields_round_trip_and_are_absent_when_not_given(tmp_path):
    inst = from_dict(_detour(6, max_moves=5))
    path = tmp_path / "i.json"
    voiopt.save(inst, path)
    assert voiopt.load(path).to_dict() == inst.to_dict()
    plain = tiny_instances(1)[0].to_dict()
    assert not {"blocked", "end", "max_moves"} & set(plain)  # the paper's files are unchanged


def test_lattice_moves_avoid_blocked_points_and_distances_go_around():
    inst = from_dict(_detour(6))
    lat = lattice.build(inst)
    b = lat.index(1, 0)
    assert lat.blocked[b] and (lat.neighbors[b] == -1).all()
    assert b not in lat.neighbors
    assert lat.to_end[lat.index(0, 0)] == 4 and lat.to_end[lat.index(2, 1)] == 1
    assert lat.from_start[lat.index(2, 0)] == 4
    # every slot's mask holds exactly the points of some legal plan (the oracle enumerates them)
    seen = [set() for _ in range(inst.horizon)]
    for plan in oracle.legal_plans(inst.to_dict()):
        for t, (x, y) in enumerate(plan["positions"]):
            seen[t].add(lat.index(x, y))
    for t in range(inst.horizon):
        assert set(np.flatnonzero(lat.on_some_plan(t)).tolist()) == seen[t]


@pytest.mark.parametrize("inst", CASES, ids=lambda i: i.name)
def test_random_legal_plans_evaluate_to_the_oracle(inst):
    d = inst.to_dict()
    oracle.check_instance(d)
    rng = random.Random(inst.name)
    lat = lattice.build(inst)
    for _ in range(5):
        plan = oracle.random_legal_plan(d, rng)
        got = voiopt.evaluate(inst, voiopt.Plan.from_dict(plan))
        want = oracle.simulate(d, plan)
        for key, value in want.items():
            assert got[key] == pytest.approx(value, rel=1e-12, abs=1e-300)
        for t, (x, y) in enumerate(plan["positions"]):
            assert lat.on_some_plan(t)[lat.index(x, y)]


def _moves(plan):
    return sum(a != b for a, b in zip(plan["positions"], plan["positions"][1:], strict=False))


def test_illegal_plans_are_rejected_naming_slot_and_rule():
    inst = from_dict(_detour(6, max_moves=4))
    d = inst.to_dict()
    good = {"positions": [[0, 0], [0, 1], [1, 1], [2, 1], [2, 0], [2, 0]], "schedule": [None, None, 0, None, None, None]}
    assert voiopt.evaluate(inst, voiopt.Plan.from_dict(good))
    cases = {
        r"^positions\[1\]: \[1, 0\] is a blocked point": [[0, 0], [1, 0], [1, 1], [2, 1], [2, 0], [2, 0]],
        r"^positions\[5\]: must equal end \[2, 0\] in the last slot, got \[2, 1\]": [[0, 0], [0, 1], [1, 1], [2, 1],
                                                                                      [2, 0], [2, 1]],
    }
    for message, positions in cases.items():
        bad = copy.deepcopy(good)
        bad["positions"] = positions
        with pytest.raises(PlanError, match=message):
            voiopt.evaluate(inst, voiopt.Plan.from_dict(bad))
        with pytest.raises(oracle.OracleError):
            oracle.simulate(d, bad)
    assert _moves(good) == 4
    inst = from_dict(_detour(7, max_moves=4))
    back_and_forth = {"positions": [[0, 0], [0, 1], [0, 0], [0, 1], [1, 1], [2, 1], [2, 0]], "schedule": [None] * 7}
    with pytest.raises(PlanError, match=r"^positions\[5\]: move number 5 breaks max_moves = 4 \(the plan makes 6 "):
        voiopt.evaluate(inst, voiopt.Plan.from_dict(back_and_forth))
    with pytest.raises(oracle.OracleError):
        oracle.simulate(inst.to_dict(), back_and_forth)


def _line(T, **extra):
    """A 4 x 1 lattice, start and end at (0, 0), one sensor at (2, 0) only in range of it."""
    d = {"area": {"width": 4, "height": 0.5}, "horizon": T, "start": [0, 0], "end": [0, 0],
         "channel": {"d_th": 0.5}, "sensors": [{"position": [0.4, 0.2], "rho": 0.5},
                                               {"position": [2, 0.2], "rho": 0.5}]}
    d.update(extra)
    return d


STRANDED = [from_dict(_line(5)), from_dict(_line(4)), from_dict(_line(9, max_moves=3)),
            from_dict(_line(9, max_moves=4)), from_dict({k: v for k, v in _line(3).items() if k != "end"})]


@pytest.mark.parametrize("inst", STRANDED + CASES[:12] + fleet_instances(6), ids=lambda i: i.name)
def test_the_stranded_sensors_are_those_no_legal_plan_uploads(inst):
    """What validate warns of, and what makes an instance's objective a foregone conclusion:
    checked against every legal plan the oracle enumerates (both legs of the walk count, as the
    slots and the budget allow)."""
    d = inst.to_dict()
    uploaded = set()
    for plan in oracle.legal_plans(d):
        for robot in plan.get("robots", [plan]):
            uploaded |= {u for u in robot["schedule"] if u is not None}
    never = set(lattice.unservable_sensors(inst))
    assert lattice.stranded_sensors(inst) == [i for i in range(inst.n_sensors) if i not in uploaded | never]


def test_the_line_strands_its_far_sensor_by_the_slots_or_by_the_budget():
    assert [lattice.stranded_sensors(i) for i in STRANDED] == [[], [1], [1], [], []]
