"""Tests of the independent oracle on hand-made tiny cases (answers derived by hand below)."""

from __future__ import annotations

import copy
import itertools
import math
import random
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

import model_oracle  # noqa: E402
from model_oracle import (  # noqa: E402
    OracleError,
    brute_force,
    check_instance,
    count_legal_plans,
    legal_plans,
    random_legal_plan,
    simulate,
)

# Default channel: g0 = 10^-5, B = 2e6 Hz, N0 = 10^-11 mW/Hz = 1e-14 W/Hz, so B*N0 = 2e-8 W
# and, for P = 1 W, P*g0 = 1e-5 W.
B = 2e6
BN0 = 2e6 * 1e-14
PG0 = 1e-5


def voi(rho, aoi, q, pg0=PG0):
    """Section 4 written independently: -B log2(1 - x)."""
    x = pg0 * rho**aoi / (BN0 * q * q + pg0)
    return -B * math.log2(1 - x)


def line3(**extra):
    """Lattice of 3 points in a line: area 2 x 0.5, step 1 -> (0,0), (1,0), (2,0)."""
    d = {
        "name": "line3",
        "area": {"width": 2, "height": 0.5},
        "horizon": 3,
        "start": [1, 0],
        "channel": {"d_th": 0.5},
        "sensors": [{"position": [2, 0], "rho": 0.5}],
    }
    d.update(extra)
    return d


# ---------------------------------------------------------------------------------------
# VoI and AoI by hand
# ---------------------------------------------------------------------------------------


def test_voi_by_hand_sensor_on_lattice_point():
    # One sensor at the start (0,0), rho 0.5, A(0)=1, q(0)=d_th=1, T=2.
    # Plan: stay, upload in slot 0 only (distance 0).
    #   t=1: A=1, q=0 -> x = 0.5 -> V = -B log2(0.5) = B = 2e6
    #   t=2: A=2, q=0 -> x = 0.25 -> V = -B log2(0.75) = B log2(4/3) ~ 830075
    d = {
        "area": {"width": 1, "height": 1},
        "horizon": 2,
        "start": [0, 0],
        "sensors": [{"position": [0, 0], "rho": 0.5}],
    }
    m = simulate(d, {"positions": [[0, 0], [0, 0]], "schedule": [0, None]})
    v2 = B * math.log2(4 / 3)
    assert m["min-voi"] == pytest.approx(v2, rel=1e-12)
    assert m["mean-min-voi"] == pytest.approx((2e6 + v2) / 2, rel=1e-12)
    assert m["max-aoi"] == 2  # A(1)=1, A(2)=2
    assert m["mean-max-aoi"] == 1.5

    # No upload: A(1)=2, A(2)=3 at q = 1 (default initial_distance = d_th):
    # x = 1e-5 rho^A / (2e-8 + 1e-5).
    m = simulate(d, {"positions": [[0, 0], [1, 0]], "schedule": [None, None]})
    assert m["min-voi"] == pytest.approx(voi(0.5, 3, 1.0), rel=1e-12)
    assert m["mean-min-voi"] == pytest.approx((voi(0.5, 2, 1.0) + voi(0.5, 3, 1.0)) / 2, rel=1e-12)
    assert m["max-aoi"] == 3 and m["mean-max-aoi"] == 2.5

    # Brute force, min-voi: staying on the sensor and uploading in both slots gives
    # V(1) = V(2) = 2e6 (x = 0.5 at q = 0); any other plan has some V with x < 0.5.
    val, plan = brute_force(d, "min-voi")
    assert val == pytest.approx(2e6, rel=1e-12)
    assert plan == {"positions": [[0.0, 0.0], [0.0, 0.0]], "schedule": [0, 0]}


def test_voi_initial_state_and_off_lattice_sensor():
    # Sensor at (0.6, 0.8): distance 1 from (0,0), out of range (d_th = 1 ... boundary, in range!)
    # distance from (1,0) is sqrt(0.16 + 0.64) = sqrt(0.8) ~ 0.894.  Custom P, A0, q0, rho.
    d = {
        "area": {"width": 1, "height": 1},
        "horizon": 2,
        "start": [0, 0],
        "sensors": [
            {
                "position": [0.6, 0.8],
                "rho": 0.8,
                "power_w": 0.01,
                "initial_aoi": 3,
                "initial_distance": 0.25,
            }
        ],
    }
    pg0 = 0.01 * 1e-5
    # Upload in slot 0 at distance 1.0 (exactly d_th, allowed), then move to (1,0) and upload
    # at distance sqrt(0.8):
    #   t=1: A=1, q=1 ; t=2: A=1, q=sqrt(0.8)
    m = simulate(d, {"positions": [[0, 0], [1, 0]], "schedule": [0, 0]})
    v1, v2 = voi(0.8, 1, 1.0, pg0), voi(0.8, 1, math.sqrt(0.8), pg0)
    assert v2 > v1
    assert m["min-voi"] == pytest.approx(v1, rel=1e-12)
    assert m["mean-min-voi"] == pytest.approx((v1 + v2) / 2, rel=1e-12)
    # No upload: A = 4, 5 at q0 = 0.25.
    m = simulate(d, {"positions": [[0, 0], [0, 1]], "schedule": [None, None]})
    assert m["min-voi"] == pytest.approx(voi(0.8, 5, 0.25, pg0), rel=1e-12)
    assert m["max-aoi"] == 5 and m["mean-max-aoi"] == 4.5


def test_two_sensors_min_over_sensors_and_fleet_upload():
    # Two robots each on a sensor, both upload in slot 0: A = (1, 1) at t=1, (2, 2) at t=2.
    d = {
        "area": {"width": 1, "height": 1},
        "horizon": 2,
        "robots": [{"start": [0, 0]}, {"start": [1, 1]}],
        "sensors": [
            {"position": [0, 0], "rho": 0.5},
            {"position": [1, 1], "rho": 0.9, "initial_aoi": 5},
        ],
    }
    plan = {
        "robots": [
            {"positions": [[0, 0], [0, 0]], "schedule": [0, None]},
            {"positions": [[1, 1], [1, 1]], "schedule": [1, None]},
        ]
    }
    m = simulate(d, plan)
    # q = 0 for both: V = -B log2(1 - rho^A); the sensor with rho 0.5 is the minimum.
    assert m["min-voi"] == pytest.approx(-B * math.log2(1 - 0.25), rel=1e-12)
    assert m["max-aoi"] == 2 and m["mean-max-aoi"] == 1.5
    # Only robot 1 uploads: sensor 0 ages 2, 3 at q=1; sensor 1 is fresh.
    plan["robots"][0]["schedule"] = [None, None]
    m = simulate(d, plan)
    assert m["max-aoi"] == 3 and m["mean-max-aoi"] == 2.5
    assert m["min-voi"] == pytest.approx(voi(0.5, 3, 1.0), rel=1e-12)


# ---------------------------------------------------------------------------------------
# Field extensions
# ---------------------------------------------------------------------------------------


def detour(T):
    # 3 x 2 lattice (area 2 x 1); (1,0) blocked; from (0,0) to (2,0) the only shortest path is
    # (0,0) -> (0,1) -> (1,1) -> (2,1) -> (2,0): 4 moves, so T = 5 is the least horizon.
    return {
        "area": {"width": 2, "height": 1},
        "horizon": T,
        "start": [0, 0],
        "end": [2, 0],
        "blocked": [[1, 0]],
        "channel": {"d_th": 0.5},
        "sensors": [{"position": [1, 1], "rho": 0.5}],
    }


def test_blocked_forces_detour():
    with pytest.raises(OracleError, match="unreachable"):
        check_instance(detour(4))
    d = detour(5)
    check_instance(d)
    # Exactly one position sequence; the sensor (1,1) is in range only at (1,1) (slot 2),
    # so 2 schedules: 2 legal plans.
    assert count_legal_plans(d) == 2
    val, plan = brute_force(d, "max-aoi")
    assert plan["positions"] == [[0, 0], [0, 1], [1, 1], [2, 1], [2, 0]]
    # Upload in slot 2: A = 2, 3, 1, 2, 3 over t = 1..5 -> max 3; without it 6.
    assert val == 3 and plan["schedule"] == [None, None, 0, None, None]
    # Without the obstacle T = 3 is enough.
    free = detour(3)
    del free["blocked"]
    check_instance(free)
    with pytest.raises(OracleError, match="slot 1.*blocked"):
        simulate(d, {"positions": [[0, 0], [1, 0], [1, 1], [2, 1], [2, 0]], "schedule": [None] * 5})


def test_end_changes_optimum():
    # line3: sensor at (2,0), d_th 0.5 -> only (2,0) is in range; start (1,0), T = 3, A0 = 1.
    # Free: move to (2,0) in slot 0, upload in slots 1 and 2: A = 2, 1, 1 -> max 2, mean 4/3.
    d = line3()
    assert brute_force(d, "max-aoi")[0] == 2
    assert brute_force(d, "mean-max-aoi")[0] == pytest.approx(4 / 3)
    # With end (0,0): positions[1] in {(0,0),(1,0)}, never (2,0): no upload, A = 2, 3, 4.
    d = line3(end=[0, 0])
    val, plan = brute_force(d, "max-aoi")
    assert val == 4 and plan["positions"][2] == [0, 0]
    assert brute_force(d, "mean-max-aoi")[0] == 3
    with pytest.raises(OracleError, match="slot 2.*end not reached"):
        simulate(d, {"positions": [[1, 0], [2, 0], [1, 0]], "schedule": [None, 0, None]})
    # min-voi also feels it: free optimum uploads at slot 1 -> V(1) = V(A=2,q=1) is the min.
    free_val = brute_force(line3(), "min-voi")[0]
    end_val = brute_force(line3(end=[0, 0]), "min-voi")[0]
    assert free_val == pytest.approx(voi(0.5, 2, 0.5))  # q0 = d_th = 0.5
    assert end_val == pytest.approx(voi(0.5, 4, 0.5))


def test_max_moves_zero_forces_staying():
    d = line3(max_moves=0)
    assert count_legal_plans(d) == 1  # stay, never in range
    val, plan = brute_force(d, "max-aoi")
    assert val == 4 and plan == {"positions": [[1, 0]] * 3, "schedule": [None] * 3}
    with pytest.raises(OracleError, match="slot 1.*too many moves"):
        simulate(d, {"positions": [[1, 0], [2, 0], [2, 0]], "schedule": [None] * 3})
    assert brute_force(line3(max_moves=1), "max-aoi")[0] == 2
    # A move back counts too: (1,0)->(2,0)->(1,0) is 2 moves.
    with pytest.raises(OracleError, match="slot 2.*too many moves"):
        simulate(
            line3(max_moves=1), {"positions": [[1, 0], [2, 0], [1, 0]], "schedule": [None, 0, None]}
        )
    # end + budget: unreachable with max_moves 1 from (1,0)... (0,0) is 1 away: fine; (2,0)
    # from start (0,0) needs 2 moves.
    with pytest.raises(OracleError, match="unreachable.*max_moves 1"):
        check_instance(line3(start=[0, 0], end=[2, 0], max_moves=1))


def swap_square(T):
    # 2 x 2 lattice; robot 0 (0,0) -> end (1,0), robot 1 (1,0) -> end (0,0).
    return {
        "area": {"width": 1, "height": 1},
        "horizon": T,
        "robots": [{"start": [0, 0], "end": [1, 0]}, {"start": [1, 0], "end": [0, 0]}],
        "channel": {"d_th": 0.5},
        "sensors": [{"position": [0, 1], "rho": 0.5}],
    }


def test_swap_rule_binds():
    # T = 2: the only per-robot plans swap the two points (no collision, only the swap rule
    # forbids it).  T = 3: slot 1 must be {(0,0),(1,0)} for each robot -> a collision or a
    # swap somewhere.  T = 4: one robot steps aside, e.g. robot 0 (0,0)->(0,1)->(1,1)->(1,0)
    # while robot 1 (1,0)->(0,0) in slot 0 ... legal.
    for T in (2, 3):
        check_instance(swap_square(T))  # each robot alone can reach its end
        assert count_legal_plans(swap_square(T)) == 0
        with pytest.raises(OracleError, match="no legal"):
            brute_force(swap_square(T), "max-aoi")
    with pytest.raises(OracleError, match=r"robots 0 and 1, slot 0: swap"):
        simulate(
            swap_square(2),
            {
                "robots": [
                    {"positions": [[0, 0], [1, 0]], "schedule": [None, None]},
                    {"positions": [[1, 0], [0, 0]], "schedule": [None, None]},
                ]
            },
        )
    d = swap_square(4)
    val, plan = brute_force(d, "max-aoi")
    simulate(d, plan)
    # Sensor (0,1) is in range only at (0,1), and nobody is there in slot 0, so A(1) = 2 and
    # max-aoi >= 2.  2 is reached with both robots taking turns on (0,1) (following, not
    # swapping): robot 0 (0,0),(0,1),(1,1),(1,0) uploads in slot 1, robot 1
    # (1,0),(0,0),(0,1),(0,0) uploads in slot 2: A(1..4) = 2, 1, 1, 2.
    assert val == 2
    follow = {
        "robots": [
            {"positions": [[0, 0], [0, 1], [1, 1], [1, 0]], "schedule": [None, 0, None, None]},
            {"positions": [[1, 0], [0, 0], [0, 1], [0, 0]], "schedule": [None, None, 0, None]},
        ]
    }
    assert simulate(d, follow)["max-aoi"] == 2
    assert simulate(d, follow)["mean-max-aoi"] == 1.5


# ---------------------------------------------------------------------------------------
# Instance validation
# ---------------------------------------------------------------------------------------


BASE = {
    "area": {"width": 2, "height": 2},
    "horizon": 3,
    "start": [0, 0],
    "sensors": [{"position": [1.5, 0.5], "rho": 0.5}],
}


def mutated(**kw):
    d = copy.deepcopy(BASE)
    for k, v in kw.items():
        if v is None:
            d.pop(k, None)
        else:
            d[k] = v
    return d


@pytest.mark.parametrize(
    "d, pattern",
    [
        (mutated(start=None), "exactly one"),
        (mutated(robots=[{"start": [1, 1]}]), "exactly one"),
        (mutated(colour="red"), "unknown"),
        (mutated(sensors=[{"position": [1, 1], "rho": 0.5, "gain": 2}]), "unknown"),
        (mutated(sensors=[]), "sensors"),
        (mutated(sensors=[{"position": [2.5, 1], "rho": 0.5}]), "outside"),
        (mutated(sensors=[{"position": [1, 1], "rho": 1.0}]), "rho"),
        (mutated(sensors=[{"position": [1, 1], "rho": 0.5, "initial_aoi": 0}]), "initial_aoi"),
        (mutated(horizon=0), "horizon"),
        (mutated(horizon=2.0), "horizon"),
        (mutated(start=[0.5, 0]), "lattice"),
        (mutated(start=[3, 0]), "outside"),
        (mutated(blocked=[[1, 1], [1, 1]]), "twice"),
        (mutated(blocked=[[1, 0.5]]), "lattice"),
        (mutated(blocked=[[0, 3]]), "outside"),
        (mutated(blocked=[[0, 0]]), "start.*blocked"),
        (mutated(end=[1, 1], blocked=[[1, 1]]), "end.*blocked"),
        (mutated(end=[2, 2]), "unreachable"),  # 4 moves > T - 1 = 2
        (mutated(end=[1, 0], max_moves=-1), "max_moves"),
        (mutated(start=None, robots=[{"start": [0, 0]}], end=[1, 0]), "not allowed"),
        (mutated(start=None, robots=[{"start": [0, 0]}, {"start": [0, 0]}]), "no legal plan"),
        (
            mutated(
                start=None,
                robots=[{"start": [0, 0], "end": [1, 1]}, {"start": [2, 2], "end": [1, 1]}],
            ),
            "no legal plan",
        ),
        (
            mutated(start=None, robots=[{"start": [0, 0]}, {"start": [2, 2], "end": [0, 0]}]),
            "robot 1.*unreachable",
        ),
        (mutated(start=None, robots=[{"start": [0, 0], "speed": 1}]), "unknown"),
        (mutated(start=None, robots=[]), "robots"),
    ],
)
def test_check_instance_rejects(d, pattern):
    with pytest.raises(OracleError, match=pattern):
        check_instance(d)


def test_check_instance_accepts_and_end_blocked_corner():
    check_instance(BASE)
    check_instance(mutated(end=[1, 1], max_moves=2))
    # corner (0,0) walled in by (1,0) and (0,1): nothing reachable, staying is fine if no end.
    walled = mutated(blocked=[[1, 0], [0, 1]])
    check_instance(walled)
    with pytest.raises(OracleError, match="unreachable"):
        check_instance(mutated(blocked=[[1, 0], [0, 1]], end=[1, 1], horizon=10))
    # step 0.5: 5 x 5 lattice points on a 2 x 2 area
    half = mutated(step=0.5, start=[0.5, 1.5], end=[2, 2], horizon=5)  # 3 + 1 = 4 half-steps
    check_instance(half)
    with pytest.raises(OracleError, match="unreachable"):
        check_instance(mutated(step=0.5, start=[0.5, 1.5], end=[2, 2], horizon=4))
    with pytest.raises(OracleError, match="lattice"):
        check_instance(mutated(step=0.5, start=[0.25, 1.5]))
    # T = 1 and end == start
    check_instance(mutated(horizon=1, end=[0, 0]))


# ---------------------------------------------------------------------------------------
# Plan legality
# ---------------------------------------------------------------------------------------


def test_simulate_rejects_illegal_flat_plans():
    d = mutated(blocked=[[1, 1]], end=[1, 0], max_moves=2)
    ok = {"positions": [[0, 0], [1, 0], [1, 0]], "schedule": [None, 0, 0]}  # (1,0)-(1.5,.5): 0.707
    simulate(d, ok)
    cases = [
        ({"positions": [[0, 0], [1, 0]], "schedule": [None] * 3}, "wrong length"),
        ({"positions": [[0, 0], [1, 0], [1, 0]], "schedule": [None] * 2}, "wrong length"),
        ({"positions": [[0, 1], [1, 1], [1, 0]], "schedule": [None] * 3}, "slot 0.*start mismatch"),
        ({"positions": [[0, 0], [0.5, 0], [1, 0]], "schedule": [None] * 3}, "slot 1.*lattice"),
        ({"positions": [[0, 0], [-1, 0], [1, 0]], "schedule": [None] * 3}, "slot 1.*outside"),
        ({"positions": [[0, 0], [1, 1], [1, 0]], "schedule": [None] * 3}, "slot 1.*blocked"),
        ({"positions": [[0, 0], [0, 1], [1, 0]], "schedule": [None] * 3}, "slot 2.*illegal move"),
        ({"positions": [[0, 0], [0, 0], [2, 0]], "schedule": [None] * 3}, "slot 2.*illegal move"),
        (
            {"positions": [[0, 0], [1, 0], [2, 0]], "schedule": [None] * 3},
            "slot 2.*end not reached",
        ),
        (
            {"positions": [[0, 0], [1, 0], [1, 0]], "schedule": [0, None, None]},
            "slot 0.*sensor 0 out of range",
        ),
        (
            {"positions": [[0, 0], [1, 0], [1, 0]], "schedule": [None, 1, None]},
            "slot 1.*schedule entry",
        ),
        (
            {"positions": [[0, 0], [1, 0], [1, 0]], "schedule": [None, True, None]},
            "slot 1.*schedule entry",
        ),
        ({"robots": [ok, ok]}, "wrong length"),
    ]
    for plan, pattern in cases:
        with pytest.raises(OracleError, match=pattern):
            simulate(d, plan)
    with pytest.raises(OracleError, match="slot 2.*too many moves"):
        simulate(
            mutated(max_moves=1), {"positions": [[0, 0], [1, 0], [2, 0]], "schedule": [None] * 3}
        )


def test_simulate_rejects_illegal_fleet_plans():
    d = {
        "area": {"width": 2, "height": 1},
        "horizon": 2,
        "robots": [{"start": [0, 0]}, {"start": [1, 0], "max_moves": 0}],
        "sensors": [{"position": [0.5, 0], "rho": 0.5}],
    }
    r0 = {"positions": [[0, 0], [0, 1]], "schedule": [0, None]}
    r1 = {"positions": [[1, 0], [1, 0]], "schedule": [None, 0]}
    simulate(d, {"robots": [r0, r1]})
    with pytest.raises(OracleError, match="flat form"):
        simulate(d, r0)
    with pytest.raises(OracleError, match=r"robots 0 and 1, slot 0: sensor 0 scheduled by two"):
        simulate(d, {"robots": [r0, dict(r1, schedule=[0, None])]})
    with pytest.raises(OracleError, match=r"robots 0 and 1, slot 1: two robots on the same point"):
        simulate(d, {"robots": [dict(r0, positions=[[0, 0], [1, 0]]), r1]})
    with pytest.raises(OracleError, match=r"robot 1, slot 1: too many moves"):
        simulate(d, {"robots": [r0, dict(r1, positions=[[1, 0], [1, 1]])]})
    with pytest.raises(OracleError, match=r"robot 1, slot 0: start mismatch"):
        simulate(d, {"robots": [r0, dict(r1, positions=[[2, 0], [2, 0]])]})
    with pytest.raises(OracleError, match=r"robots 0 and 1, slot 0: swap"):
        simulate(
            {**d, "robots": [{"start": [0, 0]}, {"start": [1, 0]}]},
            {
                "robots": [
                    dict(r0, positions=[[0, 0], [1, 0]]),
                    dict(r1, positions=[[1, 0], [0, 0]]),
                ]
            },
        )


def test_one_robot_forms_agree():
    flat = line3()
    fleet = line3()
    del fleet["start"]
    fleet["robots"] = [{"start": [1, 0]}]
    plan = {"positions": [[1, 0], [2, 0], [2, 0]], "schedule": [None, 0, 0]}
    a = simulate(flat, plan)
    assert a == simulate(flat, {"robots": [plan]}) == simulate(fleet, plan)
    assert a == simulate(fleet, {"robots": [plan]})
    assert brute_force(flat, "mean-min-voi")[0] == brute_force(fleet, "mean-min-voi")[0]
    assert "robots" in brute_force(fleet, "max-aoi")[1]


# ---------------------------------------------------------------------------------------
# Enumeration against raw enumeration filtered by simulate
# ---------------------------------------------------------------------------------------


def _raw_plans(d, points, n_sensors):
    """Every plan over the given points, legal or not (no pruning at all)."""
    T = d["horizon"]
    K = len(d["robots"]) if "robots" in d else 1
    single = [
        {"positions": [list(p) for p in ps], "schedule": list(ss)}
        for ps in itertools.product(points, repeat=T)
        for ss in itertools.product([None] + list(range(n_sensors)), repeat=T)
    ]
    if "robots" not in d:
        yield from single
    else:
        for combo in itertools.product(single, repeat=K):
            yield {"robots": list(combo)}


def _key(plan):
    entries = plan["robots"] if "robots" in plan else [plan]
    return tuple(
        (tuple(tuple(float(c) for c in p) for p in e["positions"]), tuple(e["schedule"]))
        for e in entries
    )


RAW_CASES = [
    # one robot, 2 x 2 lattice, T = 3, two sensors, an end and a budget
    (
        {
            "area": {"width": 1, "height": 1},
            "horizon": 3,
            "start": [0, 0],
            "end": [1, 1],
            "max_moves": 2,
            "sensors": [
                {"position": [0.2, 0.9], "rho": 0.6},
                {"position": [1, 0.3], "rho": 0.4, "initial_aoi": 3},
            ],
        },
        [(0, 0), (1, 0), (0, 1), (1, 1), (2, 0)],
        2,
    ),
    # one robot, blocked point, no end
    (
        {
            "area": {"width": 1, "height": 1},
            "horizon": 3,
            "start": [0, 0],
            "blocked": [[1, 0]],
            "channel": {"d_th": 0.8},
            "sensors": [{"position": [0.5, 0.5], "rho": 0.7}],
        },
        [(0, 0), (1, 0), (0, 1), (1, 1)],
        1,
    ),
    # two robots on a line of 3 points, T = 3 (swaps and collisions)
    (
        {
            "area": {"width": 2, "height": 0.5},
            "horizon": 3,
            "robots": [{"start": [0, 0]}, {"start": [1, 0], "end": [2, 0]}],
            "channel": {"d_th": 0.5},
            "sensors": [{"position": [1, 0], "rho": 0.5}],
        },
        [(0, 0), (1, 0), (2, 0)],
        1,
    ),
    # two robots on a 2 x 2 lattice, T = 2, two sensors both in range of several points
    (
        {
            "area": {"width": 1, "height": 1},
            "horizon": 2,
            "robots": [{"start": [0, 0], "max_moves": 1}, {"start": [1, 1]}],
            "sensors": [{"position": [0.5, 0.5], "rho": 0.5}, {"position": [1, 0], "rho": 0.8}],
        },
        [(0, 0), (1, 0), (0, 1), (1, 1)],
        2,
    ),
]


@pytest.mark.parametrize("d, points, n", RAW_CASES)
def test_enumeration_matches_raw_filter(d, points, n):
    # simulate(d, plan) is _evaluate(inst, _parse_plan(inst, _parse(d))); parse d once here
    # (parsing dominates the run time of ~5e4 calls).
    inst = model_oracle._parse(d)
    legal_raw = {}
    for plan in _raw_plans(d, points, n):
        try:
            m = model_oracle._evaluate(inst, model_oracle._parse_plan(inst, plan))
        except OracleError:
            continue
        legal_raw[_key(plan)] = m
    enumerated = [_key(p) for p in legal_plans(d)]
    assert len(enumerated) == len(set(enumerated))
    assert set(enumerated) == set(legal_raw)
    assert count_legal_plans(d) == len(legal_raw) > 0
    for obj, best in (
        ("min-voi", max),
        ("mean-min-voi", max),
        ("max-aoi", min),
        ("mean-max-aoi", min),
    ):
        val, plan = brute_force(d, obj)
        assert val == best(m[obj] for m in legal_raw.values())
        assert simulate(d, plan)[obj] == val


def test_brute_force_limits_and_objective():
    d = {
        "area": {"width": 4, "height": 4},
        "horizon": 8,
        "start": [0, 0],
        "sensors": [{"position": [1, 1], "rho": 0.5}],
    }
    with pytest.raises(OracleError, match="too many plans"):
        brute_force(d, "min-voi")
    with pytest.raises(OracleError, match="objective"):
        brute_force(line3(), "max-voi")


def test_random_legal_plans_are_legal():
    rng = random.Random(7)
    cases = [d for d, _, _ in RAW_CASES] + [
        detour(5),
        detour(7),
        line3(end=[0, 0]),
        swap_square(4),
        swap_square(6),
        mutated(end=[2, 2], horizon=6, max_moves=4, blocked=[[1, 1], [1, 0]]),
    ]
    for d in cases:
        legal = {_key(p) for p in legal_plans(d)}
        for _ in range(20):
            plan = random_legal_plan(d, rng)
            simulate(d, plan)
            assert _key(plan) in legal
            assert ("robots" in plan) == ("robots" in d)


def test_shipped_case_study_is_legal():
    # Smoke check on the shipped data (no expected numbers: only legality and sanity).
    import json

    root = Path(__file__).resolve().parents[2] / "instances"
    d = json.loads((root / "case-study.json").read_text())
    plan = json.loads((root / "case-study.plan.json").read_text())
    check_instance(d)
    m = simulate(d, plan)
    assert 0 < m["min-voi"] <= m["mean-min-voi"]
    assert 1 <= m["mean-max-aoi"] <= m["max-aoi"] <= 4 + d["horizon"]
    simulate(d, random_legal_plan(d, random.Random(1)))
