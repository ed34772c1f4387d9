"""The dp's slot bounds are true bounds: along an optimal plan, every label's bound (all of them
together: per-sensor, distinct ages, pairwise travel, tour; and the tour bound without the
pairwise one, which would mask it) is at least the optimum, on networks
whose optimum the independent brute force knows. The tour bound must also bind somewhere, or
these tests would not test it; and dp with and without it proves the same optima."""

from __future__ import annotations

import itertools
from types import SimpleNamespace

import numpy as np
import pytest
from conftest import field_instances, oracle_optima, tiny_instances
from oracles.bruteforce import brute_force

import voiopt
from voiopt.grid import lattice
from voiopt.objectives import OBJECTIVES
from voiopt.solvers.base import idle_plan
from voiopt.solvers.dp import solver as dp
from voiopt.solvers.dp import subsets
from voiopt.solvers.labels import kernels as core
from voiopt.solvers.labels.tables import build_tables

RTOL = 1e-9
EXACT = 1e-12  # the rounding of two sums of the same terms (subsets.reaches)


def corridor_instances(count: int = 24, seed: int = 99) -> list[voiopt.Instance]:
    """Sensors along 5 x 1 and 5 x 2 lattices with d_th = 1: their ranges lie apart, so the walk
    between them (the tour bound's subject) binds."""
    rng = np.random.default_rng(seed)
    return [voiopt.generate(int(rng.integers(2, 4)), int(rng.integers(4, 7)), width=4.0, height=float(1 + k % 2),
                            rho=(0.05, 0.95), seed=int(rng.integers(2**31)), name=f"corridor-{k:02d}")
            for k in range(count)]


CASES = corridor_instances() + tiny_instances(16, seed=2468) + field_instances(16)


def _optimum(inst: voiopt.Instance, objective: str) -> float:
    if inst.blocked or inst.end is not None or inst.max_moves is not None:
        return oracle_optima(inst)[objective]  # the oracle of MODEL.md section 9 (fields)
    return brute_force(inst, objective)[0]


def _labels_along(inst: voiopt.Instance, tab, plan) -> list[tuple[int, int, np.ndarray, float]]:
    """(slot, point, ranks, accumulated value) of the plan's label in every slot."""
    lat = lattice.build(inst)
    points = [lat.index(x, y) for x, y in plan.positions]
    ranks = tab.initial_rank.copy()
    acc = np.inf if tab.mode == core.MIN else 0.0
    out = []
    for t, (q, u) in enumerate(zip(points, plan.schedule, strict=True)):
        out.append((t, q, ranks.copy(), acc))
        if u is not None:
            ranks[u] = tab.up_rank[t, q, u]
        w = min(tab.W[i, ranks[i], t + 1] for i in range(len(ranks)))
        acc = acc + w if tab.mode == core.SUM else min(acc, w)
    return out


NONE = np.empty((0, 0), dtype=np.int64)


def _bound(tab, t, q, ranks, acc, pair, steps) -> float:
    return core.label_bounds(tab.mode, t, ranks[None, :].copy(), np.array([acc]), np.array([q], dtype=np.int32),
                             tab.W, tab.best_rank, False, True, pair, steps)[0]


@pytest.mark.parametrize("objective", list(OBJECTIVES))
def test_every_bound_is_at_least_the_optimum_along_an_optimal_plan(objective):
    assert len(CASES) >= 50
    tighter = 0
    for inst in CASES:
        opt = _optimum(inst, objective)
        r = dp.solve(inst, objective, tour_bound=False)  # an optimal plan to walk along
        assert r.status == "optimal" and abs(r.value - opt) <= RTOL * max(abs(opt), 1e-300), (inst.name, r.value, opt)
        tab = build_tables(inst, objective)
        tab.with_pair_bound()
        tab.with_tour_bound()
        target = opt * tab.to_internal
        no_pair = np.empty((0,) * 5)
        for t, q, ranks, acc in _labels_along(inst, tab, r.plan):
            every = _bound(tab, t, q, ranks, acc, tab.pair, tab.steps)
            tour = _bound(tab, t, q, ranks, acc, no_pair, tab.steps)  # the pairwise bound would mask it
            for b in (every, tour):
                assert b >= target - RTOL * max(abs(target), 1e-300), (inst.name, t, b, target)
            tighter += tour < _bound(tab, t, q, ranks, acc, no_pair, NONE)
    assert tighter > 0  # the tour bound cut some label's bound: the check above tested it


def test_dp_proves_the_same_optima_with_and_without_the_tour_bound():
    rng = np.random.default_rng(5)
    for k in range(8):
        inst = voiopt.generate(int(rng.integers(3, 7)), int(rng.integers(10, 20)), width=6.0, height=6.0,
                               seed=int(rng.integers(2**31)), blocked_fraction=0.25 if k % 2 else 0.0,
                               end="start" if k % 3 == 0 else None, max_moves=10 if k % 4 == 0 else None)
        for objective in OBJECTIVES:
            a = dp.solve(inst, objective, fast_budget=0)  # incumbents first: the tight bounds prune
            b = dp.solve(inst, objective, fast_budget=0, tour_bound=False)
            assert a.status == b.status == "optimal", (inst.name, objective)
            assert a.solver["options"]["tour_bound"] == objective.startswith("mean")  # the sums alone use it
            assert not b.solver["options"]["tour_bound"]
            assert abs(a.value - b.value) <= RTOL * max(abs(a.value), 1e-300), (inst.name, objective, a.value, b.value)


# ---------------------------------------------------------------- the subset relaxation


def test_the_subsets_run_past_their_share_only_when_the_next_is_predicted_to_fit_or_leaves_many_out():
    """subsets.until(spent, budget, cap, times, left_out, far): the share's budget; ``far``
    when the next subset leaves LEFT_OUT sensors or more out; else the cap when the next subset,
    predicted from the last two (the last time times their ratio, at least 1), would finish
    within it."""
    from voiopt.solvers.dp.subsets import LEFT_OUT, until

    assert until(5.0, 10.0, 20.0, [3.0]) == 10.0  # one subset solved: no trend to go by
    assert until(8.0, 10.0, 20.0, [1.0, 2.0]) == 20.0  # the next predicted at 4 s: ends at 12 <= 20
    assert until(17.0, 10.0, 20.0, [1.0, 2.0]) == 10.0  # it would end at 21 > 20
    assert until(15.0, 10.0, 20.0, [4.0, 2.0]) == 20.0  # a shorter last time: predicted no less than 2 s
    assert until(19.0, 10.0, 20.0, [4.0, 2.0]) == 10.0
    assert until(1.0, 10.0, 10.0, [1.0, 1.0]) == 10.0  # no time limit: no cap beyond the budget
    # many sensors beyond the next subset: the bounded pass over the whole is not expected to
    # finish, so the subsets may take ``far`` (most of the time left)
    assert until(17.0, 10.0, 20.0, [1.0, 2.0], LEFT_OUT, 36.0) == 36.0
    assert until(5.0, 10.0, 20.0, [3.0], LEFT_OUT + 3, 36.0) == 36.0
    assert until(17.0, 10.0, 20.0, [1.0, 2.0], LEFT_OUT - 1, 36.0) == 10.0
    assert until(8.0, 10.0, 20.0, [1.0, 2.0], LEFT_OUT - 1, 36.0) == 20.0  # the prediction's cap still applies
    assert until(1.0, 10.0, 10.0, [1.0, 1.0], LEFT_OUT, 10.0) == 10.0  # no time limit: the budget alone


def test_every_subset_optimum_bounds_the_optimum_of_the_whole():
    """Dropping sensors can only raise the optimum: on 54 networks and every objective, the
    brute force's optimum of each network is at most dp's optimum of each subset of its sensors
    (all subsets of 1 .. N-1 sensors), and no better than the best subset plan's value."""
    from itertools import combinations

    cases = [inst for inst in CASES if inst.n_sensors >= 2]
    assert len(cases) >= 30
    for inst in cases:
        sensors = inst.to_dict()["sensors"]
        for objective in OBJECTIVES:
            opt = _optimum(inst, objective)
            sign = 1.0 if OBJECTIVES[objective] == "max" else -1.0
            for m in range(1, inst.n_sensors):
                for keep in combinations(range(inst.n_sensors), m):
                    sub = inst.replace(sensors=[sensors[i] for i in keep])
                    r = dp.solve(sub, objective)
                    assert r.status == "optimal"
                    assert sign * r.value >= sign * opt - RTOL * max(abs(opt), 1e-300), (inst.name, keep, objective)


@pytest.mark.parametrize("objective", list(OBJECTIVES))
def test_dp_through_the_subsets_equals_the_brute_force(objective, monkeypatch):
    """fast_budget=1 sends every network down the path of large ones: incumbents, then the
    subsets (which may prove the optimum alone), then the bounded pass; the subsets run from 3
    sensors here (by default from MIN_SENSORS), for mean-min-voi alone: for the others they
    must stay off."""
    monkeypatch.setattr(subsets, "MIN_SENSORS", 3)
    used = 0
    for inst in CASES:
        r = dp.solve(inst, objective, fast_budget=1)
        opt = _optimum(inst, objective)
        assert r.status == "optimal" and abs(r.value - opt) <= RTOL * max(abs(opt), 1e-300), (inst.name, r.value, opt)
        used += "subset_bound" in r.solver
    if objective == "mean-min-voi":
        assert used >= 5, used  # networks of 3 sensors or more ran the subsets
    else:
        assert used == 0


@pytest.mark.parametrize("incumbents", [False, True])
def test_each_subset_solved_from_the_smaller_ones_is_the_brute_force_optimum_of_its_network(incumbents, monkeypatch):
    """A subset's solve starts from the least bound of the smaller subsets and, where the last
    of that bound recorded a complete pass, first searches just below that bound with the
    pass's pattern (docs/dp.md, "Subsets of the sensors"). With every pass sent down the path
    of large networks (a label budget of 1 for the subsets too), every subset proven optimal has
    the brute force's optimum of its own network, and the whole network too. Without
    incumbents every subset runs its passes; with them (beams, greedy) a pass often starts from
    the optimum itself, where a pattern built at the incumbent must not serve a pass below it."""
    monkeypatch.setattr(subsets, "MIN_SENSORS", 3)
    _without_cheap_incumbents(monkeypatch, not incumbents)
    near = checked = 0
    for k in range(10):  # 4 and 5 sensors: subsets of 2, 3 (and 4), each from the smaller ones
        inst = voiopt.generate(4 + k % 2, 5 + k % 3, width=2.0 + k % 2, height=2.0, seed=700 + k, name=f"grow-{k}")
        r = dp.solve(inst, "mean-min-voi", fast_budget=1, beam=dp.DEFAULT_BEAM, quick_beam=dp.QUICK_BEAM,
                     greedy=incumbents)
        opt = _optimum(inst, "mean-min-voi")
        assert r.status == "optimal" and abs(r.value - opt) <= RTOL * max(abs(opt), 1e-300), (inst.name, r.value, opt)
        assert r.bound >= opt - EXACT * abs(opt), (inst.name, r.bound, opt)
        smaller = np.inf  # the least bound of the smaller subsets
        for run in r.solver.get("subsets", []):
            sub = subsets.restricted(inst, run["sensors"], f"{inst.name}-sub")
            best = _optimum(sub, "mean-min-voi")
            assert run["bound"] >= best - EXACT * abs(best), (inst.name, run)  # far finer than dp.NEAR
            if run["status"] == "optimal":
                assert abs(run["bound"] - best) <= EXACT * max(abs(best), 1e-300), (inst.name, run, best)
                checked += 1
            if "bounded near the bound" in run["passes"]:  # its claim: the optimum attains the bound, or is below
                near += 1
                if run["passes"][-1] == "bounded":
                    assert best < smaller * (1 - dp.NEAR), (inst.name, run, best, smaller)
                else:
                    assert abs(best - smaller) <= RTOL * abs(smaller), (inst.name, run, best, smaller)
            smaller = min(smaller, run["bound"])
    assert checked >= 10 and near >= 3, (checked, near)


def test_without_a_time_limit_the_subsets_run_on_a_label_allowance_not_the_clock(monkeypatch):
    """With no time limit the subsets' budget is LABELS labels, not seconds, so the same solve
    takes the same subsets, passes and plan however slow the machine is: here a clock on which
    30 s pass between any two readings changes nothing (with a budget in seconds no subset ran).
    An allowance that runs out mid-subset stops it at the same point on every run, and the
    bounded pass then proves the brute force's optimum."""
    monkeypatch.setattr(subsets, "MIN_SENSORS", 3)
    inst = voiopt.generate(5, 8, width=3.0, height=2.0, seed=907, name="clock")

    def path(r):
        return r.plan, list(r.solver["passes"]), [(run["sensors"], run["status"], run["labels"], run["passes"])
                                                  for run in r.solver["subsets"]]

    calm = dp.solve(inst, "mean-min-voi", fast_budget=1)
    clock = itertools.count(0.0, 30.0)
    monkeypatch.setattr(subsets, "time", SimpleNamespace(perf_counter=lambda: next(clock)))
    busy = dp.solve(inst, "mean-min-voi", fast_budget=1)
    assert path(busy) == path(calm) and len(calm.solver["subsets"]) == 3
    first, second = (run["labels"] for run in calm.solver["subsets"][:2])
    monkeypatch.setattr(subsets, "LABELS", first + second + 1)  # one label left for the third subset
    cut, again = (dp.solve(inst, "mean-min-voi", fast_budget=1) for _ in range(2))
    assert path(cut) == path(again)
    assert [run["status"] for run in cut.solver["subsets"]] == ["optimal", "optimal", "time_limit"]
    opt = _optimum(inst, "mean-min-voi")
    assert cut.status == calm.status == "optimal" and abs(cut.value - opt) <= RTOL * abs(opt)


def test_the_subsets_certify_twelve_sensors_where_the_full_search_alone_does_not():
    inst = voiopt.generate_set(1, seed=2026, n_sensors=12, horizon=30, width=5.0, height=5.0, name="n12")[0]
    alone = dp.solve(inst, "mean-min-voi", time_limit=4, subsets=False)
    assert alone.status == "time_limit" and alone.gap > 0
    r = dp.solve(inst, "mean-min-voi", time_limit=60)
    assert r.status == "optimal" and r.value == r.bound == r.solver["subset_bound"]
    assert any(source.startswith("subset of") for source, _ in r.solver["incumbents"])
    assert r.value >= alone.value and r.bound <= alone.bound
    runs = r.solver["subsets"]  # each subset solved, one sensor more than the last, its labels counted
    assert [len(run["sensors"]) for run in runs] == list(range(subsets.FIRST, subsets.FIRST + len(runs)))
    assert all(set(a["sensors"]) < set(b["sensors"]) for a, b in zip(runs, runs[1:], strict=False))
    assert min(run["bound"] for run in runs) == pytest.approx(r.solver["subset_bound"], rel=1e-12)
    assert r.solver["labels"] == sum(p["labels"] for p in r.solver["passes"].values()) + sum(
        run["labels"] for run in runs + r.solver.get("patterns", []))
    for limit in (3, 6):  # stopped in the subsets, the pattern's pass or the bounded pass: still a bound
        cut = dp.solve(inst, "mean-min-voi", time_limit=limit)
        assert cut.status in ("time_limit", "optimal")
        assert cut.bound >= r.value - RTOL * r.value and cut.value <= r.value + RTOL * r.value


# ---------------------------------------------------------------- the pattern databases


def _moves_left(inst: voiopt.Instance, tab, plan) -> list[int]:
    """The moves the plan's label may still make in every slot, as dp counts them."""
    moved, out = 0, []
    for t, here in enumerate(plan.positions):
        moved += t > 0 and here != plan.positions[t - 1]
        out.append(tab.budget - moved if t == 0 else min(tab.budget - moved, inst.horizon - 1 - t))
    return out


@pytest.mark.parametrize("objective", ["mean-min-voi", "mean-max-aoi"])
def test_a_pattern_bound_is_at_least_the_optimum_along_an_optimal_plan(objective):
    """For every subset S of 1 .. N-1 sensors and two thresholds below the optimum (just below,
    and far below), the pattern database of S bounds every label of an optimal plan by at least
    the optimum: never drops it, never cuts it below. It must also be tighter than all the slot
    bounds somewhere, or this would not test it."""
    from itertools import combinations

    from voiopt.runtime.stop import Stop
    from voiopt.solvers.dp import patterns

    stop, tighter, checked = Stop(), 0, 0
    for inst in [inst for inst in CASES if inst.n_sensors >= 2]:
        opt = _optimum(inst, objective)
        r = dp.solve(inst, objective)
        assert r.status == "optimal" and abs(r.value - opt) <= RTOL * max(abs(opt), 1e-300), (inst.name, r.value, opt)
        tab = dp._pattern_tables(inst, objective)
        target = opt * tab.to_internal
        labels = _labels_along(inst, tab, r.plan)
        left = _moves_left(inst, tab, r.plan)
        for z in (target - 1e-9 * max(abs(target), 1.0), target - 0.5 * abs(target) - 1.0):
            for m in range(1, inst.n_sensors):
                for keep in combinations(range(inst.n_sensors), m):
                    pattern, _ = patterns.build(inst, objective, list(keep), tab, z, stop, 1, dp.search,
                                                   lambda sub: dp._pattern_tables(sub, objective))
                    assert pattern is not None
                    for t, q, ranks, acc in labels[1:]:
                        b = pattern.bound(stop, t, ranks[None, :].copy(), np.array([acc]), np.array([q], dtype=np.int32),
                                          np.array([left[t]], dtype=np.int16), np.array([np.inf]), tab.W.shape[1] - 1)[0]
                        assert b >= target - RTOL * max(abs(target), 1e-300), (inst.name, keep, t, b, target)
                        tighter += b < _bound(tab, t, q, ranks, acc, tab.pair, tab.steps) - RTOL * abs(target)
                        checked += 1
    assert checked > 1000 and tighter > 0, (checked, tighter)


def test_dp_through_the_pattern_databases_equals_the_brute_force(monkeypatch):
    """fast_budget=1 and the subsets from 3 sensors send every network of 3 or more down the
    path of large ones; patterns from 2 sensors make each of them build a pattern database for
    its bounded pass (first above the midpoint, then from the incumbent)."""
    monkeypatch.setattr(subsets, "MIN_SENSORS", 3)
    monkeypatch.setattr(dp, "PATTERN_SENSORS", 2)
    built = 0
    for inst in CASES:
        r = dp.solve(inst, "mean-min-voi", fast_budget=1)
        opt = _optimum(inst, "mean-min-voi")
        assert r.status == "optimal" and abs(r.value - opt) <= RTOL * max(abs(opt), 1e-300), (inst.name, r.value, opt)
        built += sum(run["built"] for run in r.solver.get("patterns", []))
    assert built >= 5, built


def _without_cheap_incumbents(monkeypatch, none: bool = True) -> None:
    """dp's fast pass stopped at once, with (if ``none``) no beam or greedy incumbent before the
    passes; and every pass checked: a pattern serves only passes at or above its threshold."""
    monkeypatch.setattr(dp, "FAST_BUDGET", 1)
    if none:
        for name in ("QUICK_BEAM", "DEFAULT_BEAM"):
            monkeypatch.setattr(dp, name, 0)
        monkeypatch.setattr(dp, "_greedy_plan", lambda *args: None)
    search = dp.search

    def checked_search(tab, incumbent, **kw):
        assert all(incumbent >= p.threshold for p in kw.get("patterns", ())), incumbent
        return search(tab, incumbent, **kw)

    monkeypatch.setattr(dp, "search", checked_search)


@pytest.mark.parametrize("above", [False, True])
def test_the_whole_adds_a_subsets_own_pass_and_equals_the_brute_force(monkeypatch, above):
    """The whole's bounded passes may add the pattern of a subset's own complete pass
    (dp._recorded) to that of the first subsets, in every pass at or above its threshold: they
    must still end at the brute force's optimum. Subsets from 3 sensors and no cheap incumbents
    send small networks down that path. With ``above`` the whole starts from the idle plan and
    the subsets' plans are kept from it, so that its first pass runs at the midpoint above its
    incumbent, with the subset's pattern: it finds the optimum there or proves it lower."""
    monkeypatch.setattr(subsets, "MIN_SENSORS", 3)
    _without_cheap_incumbents(monkeypatch)
    cases = CASES
    if above:
        monkeypatch.setattr(dp, "PATTERN_SENSORS", 2)
        relax = subsets.relax
        monkeypatch.setattr(subsets, "relax", lambda instance, objective, tab, stop, offer, *rest: relax(
            instance, objective, tab, stop, lambda plan, source: None, *rest))
        cases = [voiopt.generate(4 + k % 2, 5 + k % 3, width=2.0 + k % 2, height=2.0, seed=700 + k, name=f"grow-{k}")
                 for k in range(16)]
    used = first = 0
    for inst in cases:
        r = dp.solve(inst, "mean-min-voi", fast_budget=1, beam=0, quick_beam=0,
                     warm_start=idle_plan(inst) if above else None)
        opt = _optimum(inst, "mean-min-voi")
        assert r.status == "optimal" and abs(r.value - opt) <= RTOL * max(abs(opt), 1e-300), (inst.name, r.value, opt)
        assert r.bound >= opt - EXACT * abs(opt), (inst.name, r.bound, opt)
        mine = any(run["recorded"] and run["built"] for run in r.solver.get("patterns", []))
        used += mine
        first += mine and "bounded above the midpoint" in r.solver["passes"]
    assert used >= 8 and first >= (3 if above else 0), (used, first)


def test_a_subsets_own_pass_drops_labels_from_the_wholes_bounded_passes(monkeypatch):
    """The pattern of a subset's own pass is not only harmless (above) but used: where the
    whole's bounded passes add it, they keep no more labels than without it (a label it drops
    takes the labels it dominates along: their bounds are at most its), and on network d7 fewer
    (15 against 19). On networks this small the other bounds leave it little: it dropped labels
    on 1 of 150 random networks of 6 to 8 sensors; on n12-seed7-004 it is what proves the
    optimum in the minute (docs/dp.md)."""
    monkeypatch.setattr(subsets, "MIN_SENSORS", 3)
    _without_cheap_incumbents(monkeypatch)

    def bounded_labels(r):
        return sum(run["labels"] for name, run in r.solver["passes"].items() if name.startswith("bounded"))

    recorded = dp._recorded
    pairs = {}
    for inst in [*CASES, voiopt.generate(7, 9, width=3.0, height=3.0, seed=907, name="d7")]:
        monkeypatch.setattr(dp, "_recorded", recorded)
        r = dp.solve(inst, "mean-min-voi", fast_budget=1, beam=0, quick_beam=0)
        if not any(run["recorded"] and run["built"] for run in r.solver.get("patterns", [])):
            continue
        monkeypatch.setattr(dp, "_recorded", lambda *args: None)
        alone = dp.solve(inst, "mean-min-voi", fast_budget=1, beam=0, quick_beam=0)
        assert alone.value == r.value and alone.status == r.status == "optimal", inst.name
        pairs[inst.name] = (bounded_labels(r), bounded_labels(alone))
    assert len(pairs) >= 8 and all(a <= b for a, b in pairs.values()), pairs
    assert pairs["d7"][0] < pairs["d7"][1], pairs


def test_a_patterns_futures_are_the_same_on_one_thread_or_several():
    """from_layers computes a slot's futures in parts on several threads: the same values."""
    from voiopt.runtime.stop import Stop
    from voiopt.solvers.dp import patterns

    inst = voiopt.generate(12, 14, width=4.0, height=4.0, seed=31, name="futures")
    tab = dp._pattern_tables(inst, "mean-min-voi")
    layers: list = []
    out = dp.search(tab, -np.inf, record=layers)
    assert out.complete and max(len(x[1]) for x in layers) > 3 * 1024  # three parts in a slot
    one, three = (patterns.from_layers(layers, tab, -np.inf, Stop(), threads) for threads in (1, 3))
    assert all(np.array_equal(a, b) for a, b in zip(one.future, three.future, strict=True))


@pytest.mark.parametrize("max_moves", [None, 3])
def test_a_patterns_first_match_at_a_point_is_its_least_future(max_moves):
    """from_layers puts each point's labels in ascending order of f, so that the bound stops at
    the first label whose ranks (and moves left) match: it must be the least f of all the
    matches, as a scan of them all finds, for every label of an unbounded pass over the same
    network (the pattern's pass runs at 70 % of the optimum, so some labels have no match),
    and for each again with every rank one lower (so that many have several); and the layers,
    put in that order in place, give the same futures again."""
    from voiopt.runtime.stop import Stop
    from voiopt.solvers.dp import patterns

    inst = voiopt.generate(5, 8, width=2.0, height=2.0, seed=5, name="least", max_moves=max_moves)
    tab = dp._pattern_tables(inst, "mean-min-voi")
    z = tab.internal(dp.solve(inst, "mean-min-voi").value)
    z -= 0.3 * abs(z)
    kept: list = []
    every: list = []
    assert dp.search(tab, z, record=kept, collapse=False).complete
    assert dp.search(tab, -np.inf, record=every, collapse=False).complete
    pattern = patterns.from_layers(kept, tab, z, Stop())
    again = patterns.from_layers(kept, tab, z, Stop())
    assert all(np.array_equal(a, b) for a, b in zip(pattern.future, again.future, strict=True))
    matched = unmatched = 0
    lowered = [(np.maximum(r - 1, 0).astype(r.dtype), a, lf, p, o) for r, a, lf, p, o in every]  # more matches
    for t, (ranks, acc, left, pos, _) in [*enumerate(every[:len(kept)]), *enumerate(lowered[:len(kept)])]:
        off, f, s_ranks, s_left = pattern.off[t], pattern.future[t], pattern.ranks[t], pattern.left[t]
        assert all(np.all(np.diff(f[a:b]) >= 0) for a, b in zip(off[:-1], off[1:], strict=True))
        got = pattern.bound(Stop(), t, ranks, acc, pos, left, np.full(len(acc), np.inf), tab.W.shape[1] - 1)
        for k in range(len(acc)):
            lo, hi = off[pos[k]], off[pos[k] + 1]
            match = np.all(s_ranks[lo:hi] >= ranks[k], axis=1)
            if pattern.budget_lane:
                match &= s_left[lo:hi] >= left[k]
            want = acc[k] + f[lo:hi][match].min() if match.any() else -np.inf
            assert got[k] == want, (t, k, got[k], want)
            matched += bool(match.sum() > 1)
            unmatched += not match.any()
    assert matched > 100 and unmatched > 100, (matched, unmatched)


def test_a_pattern_bounds_a_label_only_through_kept_labels_of_its_ranks_and_moves_left():
    """The matching rule of a pattern database, on a hand-made pattern: a kept S-label bounds a
    label of the whole network only if its ranks, and with a budget its moves left, are at least
    the label's; the bound is the label's value plus the least such future, -inf if there is
    none. Two kept labels at point 1 with the same ranks: 1 move left and future 3, 5 moves left
    and future 10 (a point's labels in ascending order of future, as from_layers leaves them).
    (The moves-left lane is what a random network seldom exercises.)"""
    from voiopt.runtime.stop import Stop
    from voiopt.solvers.dp.patterns import Pattern

    collapsed = 9

    def bound(lane, moves, ranks=(1, 1, 0), point=1, ub=np.inf, t=0):
        pattern = Pattern(np.array([0, 1]), [np.array([[2, 2], [2, 2]], np.int16)], [np.array([1, 5], np.int16)],
                          [np.array([0, 0, 2])], [np.array([3.0, 10.0])], lane, 0.0, 2, np.zeros((2, 4, 2)),
                          np.zeros(2, np.int16))
        return pattern.bound(Stop(), t, np.array([ranks], np.int16), np.array([1.0]), np.array([point], np.int32),
                             np.array([moves], np.int16), np.array([ub]), collapsed)[0]

    assert bound(lane=1, moves=3) == 11.0  # only the label with 5 moves left has as many
    assert bound(lane=1, moves=1) == 4.0  # both have: the least future
    assert bound(lane=1, moves=6) == -np.inf  # none has: no completion beats the threshold
    assert bound(lane=0, moves=6) == 4.0  # no budget: moves left do not count
    assert bound(lane=0, moves=1, ranks=(3, 1, 0)) == -np.inf  # no kept label has rank 3 of sensor 0
    assert bound(lane=0, moves=1, ranks=(1, 1, 7)) == 4.0  # sensor 2 is not in S
    assert bound(lane=0, moves=1, point=0) == -np.inf  # no kept label at point 0
    assert bound(lane=0, moves=1, ranks=(collapsed, 1, 0)) == np.inf  # a collapsed sensor of S: bound kept
    assert bound(lane=0, moves=1, ub=2.5) == 2.5  # never looser than the bound it had
    assert bound(lane=0, moves=1, t=1) == -np.inf  # a slot the subset's pass never reached


def _apart(T: int, max_moves: int | None, end: bool = True) -> voiopt.Instance:
    """A 5 x 1 lattice, start (and end) in the middle, a sensor at each end in range of it
    alone: each round trip takes 4 moves, both together 8."""
    d = {"name": f"apart-{T}-{max_moves}-{end}", "area": {"width": 4, "height": 0.5}, "horizon": T, "start": [2, 0],
         "channel": {"d_th": 0.5}, "sensors": [{"position": [0, 0.2], "rho": 0.6, "initial_aoi": 2},
                                               {"position": [4, 0.2], "rho": 0.4}]}
    if end:
        d["end"] = [2, 0]
    if max_moves is not None:
        d["max_moves"] = max_moves
    return voiopt.core.instance.from_dict(d)


APART = [_apart(9, 6), _apart(9, 8), _apart(7, None), _apart(9, None), _apart(7, 5, end=False), _apart(6, 3)]
COVER_CASES = APART + field_instances(40, seed=4321) + CASES[-16:]


@pytest.mark.parametrize("objective", list(OBJECTIVES))
def test_the_cover_bound_is_at_least_the_optimum_and_binds_where_no_walk_reaches_every_sensor(objective):
    """cover: where no walk within the slots and the budget covers a set of sensors, one of
    them keeps its held packet, and the optimum is at most the best such sensor's worth. Held
    to the oracle's optimum on networks with blocked points, ends and budgets; it must also
    be attained on the networks built for it, or this would test nothing."""
    from voiopt.solvers.dp import cover

    finite = attained = 0
    for inst in COVER_CASES:
        tab = build_tables(inst, objective)
        b = cover.bound(inst, tab)
        if not np.isfinite(b):
            continue
        finite += 1
        opt = tab.internal(_optimum(inst, objective))
        assert b >= opt - EXACT * abs(opt), (inst.name, b, opt)
        attained += subsets.reaches(opt, b)
    assert finite >= 4 and attained >= 2, (finite, attained)


def test_the_fewest_moves_to_cover_a_set_are_those_of_the_legal_plans():
    """Held and Karp's walk over the points in range, against every legal plan the oracle
    enumerates: a set of sensors is covered within the budget exactly when some plan stands in
    range of each of them."""
    from oracles import model_oracle as oracle

    from voiopt.solvers.dp import cover

    checked = 0
    for inst in APART + field_instances(24, seed=99):
        lat = lattice.build(inst)
        N = inst.n_sensors
        points = np.flatnonzero(lat.in_range.any(axis=0) & ~lat.blocked)
        if len(points) == 0:
            continue
        walk = cover._fewest_moves(cover._Legs(lat, points, N), N)
        covered = set()
        for plan in oracle.legal_plans(inst.to_dict()):
            at = [lat.index(x, y) for x, y in plan["positions"]]
            covered.add(sum(1 << i for i in range(N) if lat.in_range[i, at].any()))
        for mask in range(1 << N):
            assert (walk[mask] <= lat.budget) == any(c & mask == mask for c in covered), (inst.name, mask)
            checked += 1
    assert checked >= 100


def test_dp_proves_the_factory_floors_aoi_optimum_by_the_cover_bound():
    """VoI-Lib's factory-n12-t100 floors: the closed walk past every sensor takes 90 moves, the
    budget is 80, so a sensor keeps its packet and the idle plan's ages are optimal. Without
    the cover bound dp left them at [59, 101] and [31.05, 51.5] in a minute."""
    from voiopt.voilib import library as voilib

    inst = voilib.instances()["factory-n12-t100-000"]
    for objective, value in (("max-aoi", 101), ("mean-max-aoi", 51.5)):
        r = dp.solve(inst, objective, time_limit=30)
        assert (r.status, r.value, r.bound, r.solver["cover_bound"]) == ("optimal", value, value, value)


def test_above_the_exact_programmes_reach_the_stranded_sensors_alone_still_bound(monkeypatch):
    """Over MAX_SENSORS the bound takes only the sets of one sensor (the stranded ones): still a
    true bound on the oracle's networks, and on a factory floor of 30 sensors whose budget of
    40 moves strands 12 it proves the AoI optimum at once (a minute's search left it at 35)."""
    from voiopt.solvers.dp import cover

    monkeypatch.setattr(cover, "MAX_SENSORS", 0)
    finite = 0
    for inst in COVER_CASES:
        tab = build_tables(inst, "max-aoi")
        b = cover.bound(inst, tab)
        if np.isfinite(b):
            finite += 1
            opt = tab.internal(_optimum(inst, "max-aoi"))
            assert b >= opt - EXACT * abs(opt), (inst.name, b, opt)
    assert finite >= 3
    monkeypatch.undo()
    floor = voiopt.generate_set(1, seed=5, preset="factory", n_sensors=30, horizon=100, max_moves=40)[0]
    assert len(lattice.stranded_sensors(floor)) == 12
    r = dp.solve(floor, "mean-max-aoi", time_limit=30)
    assert (r.status, r.value, r.solver["cover_bound"]) == ("optimal", 51.5, 51.5)
