"""The label-setting programme against the brute force, the MILP, its limits and its options."""

from __future__ import annotations

import importlib.util
import itertools

import numpy as np
import pytest
from conftest import tiny_instances
from oracles.bruteforce import brute_force

import voiopt
from voiopt.core.instance import from_dict
from voiopt.errors import OptionError
from voiopt.networks.generate import case_study as case_study_instance
from voiopt.objectives import OBJECTIVES
from voiopt.solvers.dp import solver as dp
from voiopt.solvers.labels import search

RTOL = 1e-6


def close(a: float, b: float) -> bool:
    return abs(a - b) <= RTOL * max(abs(a), abs(b), 1e-300)


@pytest.fixture(scope="module")
def tiny():
    return tiny_instances(30, seed=12345)


@pytest.mark.parametrize("objective", list(OBJECTIVES))
def test_dp_equals_brute_force(tiny, objective):
    for inst in tiny:
        value, _ = brute_force(inst, objective)
        r = dp.solve(inst, objective)
        assert r.status == "optimal", (inst.name, r.solver)
        assert close(r.value, value), (inst.name, r.value, value)
        assert close(r.bound, r.value)


@pytest.mark.parametrize("objective", list(OBJECTIVES))
@pytest.mark.parametrize(
    "options",
    [
        dict(greedy=False, beam=0, quick_beam=0),  # no incumbent: dominance, bounds, collapse
        dict(greedy=False, beam=0, quick_beam=0, fast_budget=0, collapse=False),
        dict(fast_budget=0),  # incumbents first, the pairwise travel bound on
        dict(fast_budget=0, tdma=False),
        dict(greedy=False, beam=0, quick_beam=0, bounding=False, collapse=False),  # plain dominance
    ],
    ids=["no-incumbent", "no-collapse", "pair-bound", "no-tdma", "dominance-only"],
)
def test_every_ingredient_is_exact_on_its_own(objective, options):
    for inst in tiny_instances(12, seed=777):
        value, _ = brute_force(inst, objective)
        r = dp.solve(inst, objective, **options)
        assert r.status == "optimal" and close(r.value, value), (inst.name, options, r.value, value)


def test_through_the_registry_and_deterministic(case_study):
    a = voiopt.solve(case_study, method="dp", objective="mean-min-voi")
    b = voiopt.solve(case_study, method="dp", objective="mean-min-voi")
    assert a.status == "optimal" and a.method == "dp"
    assert a.plan == b.plan and a.value == b.value


@pytest.mark.parametrize("objective", list(OBJECTIVES))
def test_time_limit_returns_a_legal_plan_and_a_valid_bound(objective):
    inst = voiopt.generate(8, 40, width=8, height=8, seed=3)
    r = dp.solve(inst, objective, time_limit=1e-3)
    voiopt.evaluate(inst, r.plan)  # legal (raises otherwise)
    if OBJECTIVES[objective] == "max":
        assert r.bound >= r.value
    else:
        assert r.bound <= r.value
    if objective.startswith("mean"):
        assert r.status == "time_limit" and r.solver["stopped"] == "time limit of 0.001 s reached"
    else:  # the bottleneck objectives may be closed by the incumbent and the first bound at once
        assert r.status == "time_limit" or (r.status == "optimal" and r.gap == 0)


def test_memory_limit_stops_with_the_best_plan_and_bound():
    inst = voiopt.generate(8, 30, seed=5)
    limit = dp.table_bytes(inst) / 1e9 * 1.01  # the tables fit (the estimate is an upper bound); the labels do not
    # without the subsets, which prove this network's optimum within the limit (their tables are smaller)
    r = dp.solve(inst, "mean-min-voi", memory_limit=limit, subsets=False)
    assert r.status == "memory_limit" and r.solver["stopped"] == f"memory limit of {limit:g} GB reached"
    assert r.bound >= r.value and voiopt.evaluate(inst, r.plan)["mean-min-voi"] == r.value


def test_tables_over_the_memory_limit_are_refused_before_any_allocation():
    inst = voiopt.generate(2, 6000, seed=5)  # the best-rank table alone, 2 N n T^2 bytes, is 5 GB
    with pytest.raises(OptionError, match=r"--memory-limit: dp's tables need.* over the limit of 4 GB"):
        dp.solve(inst, "mean-min-voi")


def test_warm_start_is_used_and_optimum_unchanged(case_study):
    greedy = voiopt.solve(case_study, method="greedy", objective="mean-max-aoi")
    r = dp.solve(case_study, "mean-max-aoi", warm_start=greedy.plan)
    plain = dp.solve(case_study, "mean-max-aoi", greedy=False)
    assert r.solver["incumbents"][0][0] == "warm_start"
    assert r.status == plain.status == "optimal" and close(r.value, plain.value)


def test_bad_limits_are_rejected(case_study):
    with pytest.raises(OptionError):
        dp.solve(case_study, "min-voi", time_limit=0)
    with pytest.raises(OptionError):
        dp.solve(case_study, "min-voi", memory_limit=-1)


HAVE_MILP = importlib.util.find_spec("voiopt.solvers.milp.solver") is not None and importlib.util.find_spec("highspy")


@pytest.mark.skipif(not HAVE_MILP, reason="the MILP solver is not in this tree")
@pytest.mark.parametrize("objective", list(OBJECTIVES))
def test_dp_and_milp_agree_and_milp_accepts_the_dp_plan(objective):
    for seed in range(3):
        inst = voiopt.generate(2, 5, width=2, height=2, seed=100 + seed, rho=(0.3, 0.9))
        d = dp.solve(inst, objective)
        m = voiopt.solve(inst, method="milp", objective=objective, time_limit=60)
        assert d.status == "optimal" and m.status == "optimal", (inst.name, m.solver)
        assert close(d.value, m.value), (inst.name, d.value, m.value)
        w = voiopt.solve(inst, method="milp", objective=objective, time_limit=60, warm_start=d.plan)
        assert w.status == "optimal" and close(w.value, d.value)


@pytest.mark.parametrize("objective", ["mean-min-voi", "max-aoi"])
def test_progress_shows_incumbent_bound_and_gap_in_the_objectives_units(objective):
    """The bar's bound is max(incumbent, the layer's largest label bound), in the objective's
    own units and sense; nothing is shown before an incumbent exists."""
    import numpy as np

    tab = dp.build_tables(voiopt.generate(3, 8, seed=5), objective)
    best, layer = (100.0, [120.0, 90.0]) if objective == "mean-min-voi" else (10.0, [8.0, 9.0])
    text = search._progress_bound(tab, tab.internal(best), tab.internal(np.array(layer)))
    bound = max(layer) if objective == "mean-min-voi" else min(layer)
    assert text == f"  best {best:.6g}  bound {bound:.6g}  gap {100 * abs(bound - best) / abs(bound):.3g} %"
    assert search._progress_bound(tab, -np.inf, np.array(layer)) == ""


def test_threads_keep_every_label_plan_and_bound(monkeypatch):
    """threads=K expands K chunks of a slot at once; the chunks are independent, so every pass
    keeps the same labels whatever K is (this network needs the beam passes and the subsets,
    whose own bounded passes use the threads too). The subsets run within a time budget, where
    the wider beam passes run only if predicted to fit a share of the time left: under load
    the two runs took different passes, so here they always run."""
    monkeypatch.setattr(dp, "WIDEN_SHARE", float("inf"))
    inst = voiopt.generate(8, 30, seed=5)
    one = dp.solve(inst, "mean-min-voi")
    two = dp.solve(inst, "mean-min-voi", threads=2)
    assert one.status == two.status == "optimal" and "beam 16" in one.solver["passes"]
    assert one.plan == two.plan and one.value == two.value and one.bound == two.bound
    assert one.solver["passes"] == two.solver["passes"] and one.solver["labels"] == two.solver["labels"]
    assert [s["labels"] for s in one.solver["subsets"]] == [s["labels"] for s in two.solver["subsets"]]
    monkeypatch.setattr(search, "CHUNK_WORK", 2000)  # its layers cut into many chunks, not left whole as small
    inst = voiopt.generate(6, 30, seed=5)  # a bounded pass from just below the optimum
    tab = dp.build_tables(inst, "mean-min-voi")
    tab.with_tour_bound()
    inc = tab.internal(dp.solve(inst, "mean-min-voi").value) * (1 - 1e-3)
    passes = [dp.search(tab, inc, threads=k) for k in (1, 2, 3)]
    assert passes[0].complete and passes[0].labels > 10_000 and passes[0].plan is not None
    for p in passes[1:]:
        assert (p.labels, p.generated, p.value) == (passes[0].labels, passes[0].generated, passes[0].value)
        assert all((a == b).all() for a, b in zip(p.plan, passes[0].plan, strict=True))
    assert (one.solver["options"]["threads"], two.solver["options"]["threads"]) == (1, 2)


def test_a_small_layer_is_not_cut_into_tiny_calls():
    """Cutting every layer into 4 x threads calls made a beam of 2 (layers of a few hundred
    labels) twice as slow on two threads: no call is cut below CHUNK_WORK / 16 pairs; a layer
    of more than CHUNK_WORK still gives each thread about four."""
    tiny = np.full(5, 1000)  # 5,000 (label, upload) pairs in all
    assert search._chunks(tiny, 1) == search._chunks(tiny, 2) == [(0, 5)]
    medium = search._chunks(np.full(30, 1000), 2)  # 30,000: calls of 6 points (6,000 pairs), not 8 of 3.75
    assert medium == [(0, 6), (6, 12), (12, 18), (18, 24), (24, 30)]
    large = search._chunks(np.full(400, 1000), 2)
    assert len(large) == 8 and large[0][0] == 0 and large[-1][1] == 400
    assert all(hi == lo for (_, hi), (lo, _) in itertools.pairwise(large))
    assert search._chunks(np.full(400, 1000), 1) == [(0, 100), (100, 200), (200, 300), (300, 400)]


def test_threads_stop_at_the_time_limit_and_are_checked():
    inst = voiopt.generate(8, 40, width=8, height=8, seed=3)
    r = dp.solve(inst, "mean-min-voi", time_limit=0.5, threads=2)
    assert r.status == "time_limit" and r.runtime_s < 0.5 + 1.0 and r.bound >= r.value
    assert voiopt.evaluate(inst, r.plan)["mean-min-voi"] == r.value
    for bad in (0, 1.5, True, 257):
        with pytest.raises(OptionError, match="--threads: must be an integer from 1 to 256"):
            dp.solve(inst, "mean-min-voi", threads=bad)
    fleet = voiopt.generate(3, 6, width=2.0, height=2.0, seed=0, robots=2)
    with pytest.raises(OptionError, match="--threads: an option of the one-robot dp"):
        dp.solve(fleet, "mean-min-voi", threads=2)


def test_the_incumbents_beam_widens_with_the_cheap_bound_while_the_time_left_allows():
    """dp._widening: the beam pass at ``beam`` (the solve's bounds), then 2 and 4 times as wide
    with the cheap bound alone; a next pass predicted (2.5 x the last) past WIDEN_SHARE of the
    time left is not started, nor one after a stop."""
    import time as time_mod

    class FakeStop:
        def __init__(self, left, reason=None):
            self.left, self.reason = left, reason

        def remaining(self):
            return self.left

        def check(self):
            return self.reason

    def run(stop, seconds=0.0):
        calls = []

        def beam_pass(width, **kw):
            calls.append((width, kw.get("tdma", "solve's")))
            time_mod.sleep(seconds)
        dp._widening(beam_pass, 16, stop)
        return calls

    assert dp.WIDEN == 4
    assert run(FakeStop(None)) == [(16, "solve's"), (32, False), (64, False)]  # no time limit
    assert run(FakeStop(100.0)) == [(16, "solve's"), (32, False), (64, False)]
    assert run(FakeStop(1.0), seconds=0.05) == [(16, "solve's")]  # 2.5 x 0.05 s > 10 % of 1 s
    assert run(FakeStop(100.0, reason="interrupted")) == [(16, "solve's")]


def test_a_limit_stops_the_build_of_the_value_table_and_its_blocks_change_no_bit(monkeypatch):
    """W's worths grow as T^2 (libm per entry): at T = 1108 building them took 6 s past a 1.8 s
    limit, in dp and in beam (a fuzz campaign). They are now computed a block at a time, the
    stop rule checked between blocks; stopped there, the robot heads for its end (or stays)
    without uploads. The blocks change no bit of W."""
    from voiopt.solvers.dp import beam
    from voiopt.solvers.labels import tables

    inst = voiopt.generate(3, 40, seed=6, end="random")
    whole = tables.build_tables(inst, "mean-min-voi").W
    monkeypatch.setattr(tables, "VOI_BLOCK", 5)
    assert np.array_equal(tables.build_tables(inst, "mean-min-voi").W, whole)
    for solve in (dp.solve, beam.solve):
        r = solve(inst, "mean-min-voi", time_limit=1e-9)
        assert r.status == "time_limit" and all(u is None for u in r.plan.schedule)
        assert r.plan.positions[-1] == inst.end and r.metrics == voiopt.evaluate(inst, r.plan)


def test_the_value_table_checks_the_stop_rule_after_every_block(monkeypatch):
    """A block of W held 2^18 worths less a few, and the rule was checked once 2^18 had been
    counted: after every second block (at T = 1633 on a busy machine, 1.7 s for a 0.3 s limit)."""
    from voiopt.core import physics
    from voiopt.runtime.stop import Stop
    from voiopt.solvers.labels import tables

    inst = voiopt.generate(3, 40, seed=6, end="random")
    monkeypatch.setattr(tables, "VOI_BLOCK", 1000)
    since, most = [0], [0]
    voi, check = physics.voi, Stop.check
    monkeypatch.setattr(physics, "voi", lambda *a: (since.__setitem__(0, since[0] + np.size(a[0])), voi(*a))[1])
    monkeypatch.setattr(Stop, "check", lambda self, *a: (most.__setitem__(0, max(most[0], since[0])),
                                                         since.__setitem__(0, 0), check(self, *a))[2])
    tables.build_tables(inst, "mean-min-voi", Stop())
    assert 0 < max(most[0], since[0]) <= 1000


def test_a_range_past_the_area_is_not_refused_as_too_large():
    """Any d_th past the area's diagonal gives the same network; the memory estimates counted
    (2 d_th / step + 2)^2 points in range, and refused the case study at d_th = 1000 (dp,
    28.5 GB) and 100 (milp, 4.9 GB), a review found. Points in range are at most the lattice's."""
    d = case_study_instance().to_dict()
    d["channel"]["d_th"] = 8.0  # past the 5 x 5 area's diagonal
    want = voiopt.solve(from_dict(d), method="dp", objective="min-voi").value
    d["channel"]["d_th"] = 1e9
    far = from_dict(d)
    for method in ("dp", "milp"):
        r = voiopt.solve(far, method=method, objective="min-voi", time_limit=60)
        assert r.status == "optimal" and r.value == pytest.approx(want, rel=1e-9), method
