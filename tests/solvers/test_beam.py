"""The beam planner: legal plans never better than the proven optimum, exact with a wide beam on
tiny networks, the best width kept, and the stop rule honoured."""

from __future__ import annotations

import pytest
from conftest import tiny_instances
from oracles.bruteforce import brute_force

import voiopt
from voiopt.errors import OptionError
from voiopt.objectives import OBJECTIVES, better
from voiopt.solvers.dp import beam


@pytest.mark.parametrize("objective", list(OBJECTIVES))
def test_beam_is_legal_and_bounded_by_the_optimum(objective):
    for inst in tiny_instances(12, seed=3):
        best, _ = brute_force(inst, objective)
        r = beam.solve(inst, objective)
        assert r.status == "feasible" and r.bound is None
        assert not better(objective, r.value, best) or r.value == pytest.approx(best, rel=1e-9)
        assert r.value == pytest.approx(best, rel=1e-9)  # tiny networks: a beam of 64 holds every label


def test_widths_only_improve_and_options_are_checked():
    inst = voiopt.generate(6, 30, seed=4)
    r = beam.solve(inst, "mean-min-voi", max_width=32)
    values = [p["value"] for p in r.solver["passes"]]
    assert values == sorted(values) and [p["width"] for p in r.solver["passes"]] == [2, 4, 8, 16, 32]
    assert r.value == values[-1]
    with pytest.raises(OptionError, match="max_width: must be an integer >= 1"):
        beam.solve(inst, "mean-min-voi", max_width=0)


def test_a_time_limit_keeps_the_best_plan_so_far():
    inst = voiopt.generate(10, 60, width=10, height=10, seed=2)
    r = beam.solve(inst, "mean-min-voi", time_limit=0.5)
    assert r.status == "time_limit" and r.runtime_s < 3.0
    voiopt.evaluate(inst, r.plan)


def test_the_default_widths_are_bounded_by_work_not_the_clock(monkeypatch):
    """On a 26-sensor factory floor the default widths to 64 took 77 s (issue 47); the default
    schedule now stops widening when the next pass, about twice the last one's labels, would
    pass LABEL_BUDGET: labels, so the plan depends on the instance alone."""
    inst = voiopt.generate(6, 30, seed=1)
    full = beam.solve(inst, "mean-min-voi")
    labels = [p["labels"] for p in full.solver["passes"]]
    assert [p["width"] for p in full.solver["passes"]] == list(beam.WIDTHS)  # the paper's size: every width fits
    assert sum(labels) <= beam.LABEL_BUDGET
    monkeypatch.setattr(beam, "LABEL_BUDGET", labels[0] + 2 * labels[0] - 1)  # the next pass would not fit
    short = beam.solve(inst, "mean-min-voi")
    assert [p["width"] for p in short.solver["passes"]] == [2] and short.solver["label_budget"] == beam.LABEL_BUDGET
    assert short.plan == beam.solve(inst, "mean-min-voi").plan  # deterministic
    assert short.value == full.solver["passes"][0]["value"]
    explicit = beam.solve(inst, "mean-min-voi", max_width=8)  # an explicit width runs every width up to it
    assert [p["width"] for p in explicit.solver["passes"]] == [2, 4, 8] and explicit.solver["label_budget"] is None
