"""Exact expected objectives of plans under lossy links (voiopt.core.expectation) against a
brute-force enumeration of every outcome of every upload, each realised plan valued by the
independent oracle simulator (tests/oracles/model_oracle.py), with the success probabilities
written out from MODEL.md section 11 here."""

from __future__ import annotations

import copy
import itertools
import math
import random

import pytest
from conftest import fleet_instances, tiny_instances
from hypothesis import given, settings
from hypothesis import strategies as st
from oracles import model_oracle as oracle

import voiopt
from voiopt.core.expectation import expected_metrics
from voiopt.core.instance import from_dict

NAMES = ("min-voi", "mean-min-voi", "max-aoi", "mean-max-aoi")


def p_by_hand(d: dict, links: dict, i: int, dist: float) -> float:
    s = d["sensors"][i]
    if "success" in s:
        return s["success"]
    if links["model"] == "bernoulli":
        return links["success"]
    ch = d.get("channel", {})
    gamma = 10 ** (links["snr_threshold_db"] / 10)
    bn0 = ch.get("bandwidth_hz", 2e6) * 10 ** (ch.get("noise_dbm_per_hz", -110.0) / 10) / 1000
    pg0 = s.get("power_w", 1.0) * 10 ** (ch.get("g0_db", -50.0) / 10)
    return math.exp(-gamma * bn0 * dist * dist / pg0)


def cases():
    rng = random.Random(5)
    lossy = [{"model": "bernoulli", "success": 0.7}, {"model": "bernoulli", "success": 0.25},
             {"model": "rayleigh", "snr_threshold_db": 27.0}, {"model": "rayleigh", "snr_threshold_db": 20.0}]
    out = []
    for n, inst in enumerate(tiny_instances(16, seed=321) + fleet_instances(6, seed=99)):
        d = inst.to_dict()
        plans = [oracle.random_legal_plan(d, rng) for _ in range(40)]
        plan = max(plans, key=lambda q: min(8, sum(u is not None for r in q.get("robots", [q]) for u in r["schedule"])))
        links = lossy[n % len(lossy)]
        dl = copy.deepcopy(d) | {"links": links}
        if n % 3 == 1:
            dl["sensors"][0]["success"] = 0.5  # a per-sensor override
        if n % 5 == 2:
            dl["sensors"][-1]["success"] = 1.0  # a sensor whose uploads never fail
        out.append(pytest.param(dl, plan, id=f"{inst.name}-{links['model']}"))
    return out


@pytest.mark.parametrize("d,plan", cases())
def test_expected_metrics_equal_brute_force(d, plan):
    inst = from_dict(d)
    want = brute_expectation(d, plan)
    got = expected_metrics(inst, voiopt.Plan.from_dict(plan))
    for name in NAMES:
        assert got[name] == pytest.approx(want[name], rel=1e-9, abs=1e-300), name


def brute_expectation(d: dict, plan: dict) -> dict[str, float]:
    """Sum over all 2^(uploads) outcomes of probability x the oracle's metrics of the realised
    plan (failed uploads set to null), on the instance without its lossy fields (the oracle
    knows sections 1-10 only)."""
    plain = {k: v for k, v in d.items() if k != "links"}
    plain["sensors"] = [{k: v for k, v in s.items() if k != "success"} for s in d["sensors"]]
    probs = copy.deepcopy(plain)
    for s, orig in zip(probs["sensors"], d["sensors"], strict=True):
        if "success" in orig:
            s["success"] = orig["success"]
    return _brute(plain, probs, d["links"], plan)


def _brute(plain, probs, links, plan):
    robots = plan["robots"] if "robots" in plan else [plan]
    ups = []
    for k, r in enumerate(robots):
        for t, u in enumerate(r["schedule"]):
            if u is not None:
                x, y = r["positions"][t]
                sx, sy = plain["sensors"][u]["position"]
                ups.append((k, t, p_by_hand(probs, links, u, math.hypot(x - sx, y - sy))))
    total = dict.fromkeys(NAMES, 0.0)
    for outcome in itertools.product((True, False), repeat=len(ups)):
        prob = 1.0
        realised = copy.deepcopy(robots)
        for ok, (k, t, p) in zip(outcome, ups, strict=True):
            prob *= p if ok else 1.0 - p
            if not ok:
                realised[k]["schedule"][t] = None
        if prob == 0.0:
            continue
        m = oracle.simulate(plain, {"robots": realised} if "robots" in plan else realised[0])
        for name in NAMES:
            total[name] += prob * m[name]
    return total


@pytest.mark.parametrize("links", [None, {"model": "bernoulli", "success": 1}, {"model": "bernoulli", "success": 1.0},
                                   {"model": "rayleigh", "snr_threshold_db": -1e6}])
def test_without_losses_expected_metrics_are_the_simulators_bit_for_bit(links):
    rng = random.Random(11)
    for inst in tiny_instances(8, seed=8) + fleet_instances(3, seed=5):
        d = inst.to_dict()
        if links is not None:
            d["links"] = links
        lossless = from_dict(d)
        for _ in range(3):
            plan = voiopt.Plan.from_dict(oracle.random_legal_plan(inst.to_dict(), rng))
            assert expected_metrics(lossless, plan) == voiopt.evaluate(inst, plan)


def test_a_plan_without_uploads_is_valued_as_lossless(case_study):
    d = case_study.to_dict() | {"links": {"model": "bernoulli", "success": 0.3}}
    lossy = from_dict(d)
    plan = voiopt.Plan((tuple(case_study.start),) * case_study.horizon, (None,) * case_study.horizon)
    got, want = expected_metrics(lossy, plan), voiopt.evaluate(case_study, plan)
    for name in NAMES:
        assert got[name] == pytest.approx(want[name], rel=1e-12)


def test_an_illegal_plan_is_a_plan_error(case_study):
    lossy = from_dict(case_study.to_dict() | {"links": {"model": "bernoulli", "success": 0.3}})
    plan = voiopt.Plan(((9.0, 9.0),) * case_study.horizon, (None,) * case_study.horizon)
    with pytest.raises(voiopt.PlanError, match=r"positions\[0\]"):
        expected_metrics(lossy, plan)


SMALL = tiny_instances(12, seed=4040)


@settings(max_examples=40, deadline=None, derandomize=True, database=None)
@given(st.integers(0, len(SMALL) - 1), st.integers(0, 2**31),
       st.lists(st.one_of(st.just(1.0), st.floats(1e-6, 1.0)), min_size=3, max_size=3))
def test_expected_metrics_equal_brute_force_for_any_probabilities(k, seed, probs):
    """Per-sensor probabilities anywhere in (0, 1], 1 included (a sensor that never fails)."""
    d = SMALL[k].to_dict()
    plans = [oracle.random_legal_plan(d, random.Random(seed + j)) for j in range(6)]
    plan = max(plans, key=lambda q: min(8, sum(u is not None for u in q["schedule"])))
    dl = copy.deepcopy(d) | {"links": {"model": "bernoulli", "success": 0.5}}
    for s, p in zip(dl["sensors"], probs, strict=False):
        s["success"] = p
    got = expected_metrics(from_dict(dl), voiopt.Plan.from_dict(plan))
    want = brute_expectation(dl, plan)
    for name in NAMES:
        assert got[name] == pytest.approx(want[name], rel=1e-9, abs=1e-300), name
