"""Gap reports on lossy instances (MODEL.md section 11): every value says exact or Monte Carlo
(with its CI and scenario count), every bound its kind, the headline gap is to a proven bound
only and the information relaxation's gap is labelled statistical."""

from __future__ import annotations

import csv
import json

import pytest
from oracles.expectimax import oracle, tiny

import voiopt
from voiopt.cli.main import main
from voiopt.core import instance as instance_mod
from voiopt.core.result import BoundKind, Evaluation, Result
from voiopt.experiments import gaps as report
from voiopt.experiments.lossy_gaps import LOSSY_COLUMNS, half_width, lossy_fields
from voiopt.runtime.status import Status
from voiopt.solvers.policy import replan
from voiopt.solvers.qlearning import lossy as qlossy

LINKS = {"model": "bernoulli", "success": 0.6}
OBJECTIVE = "mean-min-voi"


@pytest.fixture(scope="module")
def nets(tmp_path_factory):
    folder = tmp_path_factory.mktemp("lossy-nets")
    for seed, links in ((1, LINKS), (2, LINKS), (3, None)):  # two lossy networks and a lossless one
        (folder / f"tiny{seed}.json").write_text(json.dumps(tiny(seed, 3, 5, links)))
    return folder


def read_rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def num(x: str) -> float | None:
    return None if x == "" else float(x)


@pytest.fixture(scope="module")
def lossy_report(nets, tmp_path_factory):
    """policy-dp, replan, dp, greedy and qlearning (2 seeds), replan and qlearning valued by
    Monte Carlo (their exact enumeration turned off), with an information-relaxation bound."""
    out = tmp_path_factory.mktemp("report")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(replan, "EXACT_STATES", 0)
        mp.setattr(qlossy, "EXACT_STATES", 0)
        code = main(["gap-report", str(nets), "--methods", "policy-dp,replan,dp,greedy,qlearning", "--episodes",
                     "2000", "--seeds", "2", "--samples", "300", "--ir-samples", "20", "-o", str(out), "--quiet"])
    assert code == 0
    return out, read_rows(out / "gaps.csv")


def test_the_lossy_columns_label_every_value_and_bound(lossy_report, nets):
    out, rows = lossy_report
    assert list(rows[0]) == report.GAP_COLUMNS + LOSSY_COLUMNS
    assert len(rows) == 3 * 6  # qlearning over two seeds
    for row in rows:
        if row["instance"] == "tiny3":  # lossless: the lossy columns are empty
            assert all(row[c] == "" for c in LOSSY_COLUMNS)
            continue
        seed = "" if row["seed"] == "" else f"__seed{row['seed']}"
        r = voiopt.load_result(out / "results" / f"{row['instance']}__{row['method']}{seed}.json")
        assert (row["evaluation"], num(row["value"]), row["bound_kind"]) == (r.evaluation, r.value, r.bound_kind or "")
        if row["evaluation"] == Evaluation.MONTE_CARLO:
            low, high = num(row["value_ci_low"]), num(row["value_ci_high"])
            assert low <= num(row["value"]) <= high and int(row["samples"]) == r.samples == 300
            assert [low, high] == list(r.value_ci)
            assert num(row["gap_ci_low"]) <= num(row["gap"]) <= num(row["gap_ci_high"])
        else:
            assert row["samples"] == row["value_ci_low"] == row["gap_ci_low"] == ""
    assert {r["evaluation"] for r in rows if r["method"] in ("replan", "qlearning") and r["instance"] != "tiny3"} \
        == {"monte-carlo"}
    assert sum(1 for r in rows if r["method"] == "qlearning" and r["instance"] == "tiny1") == 2


def test_policy_dp_is_exact_and_optimal_and_its_bound_is_the_headline(lossy_report, nets):
    out, rows = lossy_report
    for name in ("tiny1", "tiny2"):
        mine = [r for r in rows if r["instance"] == name]
        pdp = next(r for r in mine if r["method"] == "policy-dp")
        assert (pdp["status"], pdp["evaluation"], pdp["bound_kind"]) == ("optimal", "exact", "exact")
        assert num(pdp["gap"]) == pytest.approx(0, abs=1e-12)
        exact = num(pdp["bound"])
        assert exact == pytest.approx(oracle(tiny(int(name[-1]), 3, 5, LINKS), OBJECTIVE), rel=1e-9)
        proven = [num(r["bound"]) for r in mine if r["bound_kind"] in ("exact", "lossless")]
        for r in mine:
            # the headline bound is the tightest proven one, never the statistical one
            assert (num(r["best_bound"]), r["best_bound_kind"]) == (min(proven), "exact") == (exact, "exact")
            assert num(r["value"]) <= exact * (1 + 1e-9) or r["evaluation"] == "monte-carlo"
            if r["evaluation"] == "monte-carlo":
                assert num(r["value_ci_low"]) <= exact  # an estimate's CI reaches below the optimum
            statistical = [num(x["bound"]) for x in mine if x["bound_kind"] == "information-relaxation"]
            assert statistical and num(r["statistical_bound"]) == min(statistical)
            assert r["statistical_bound_kind"] == "information-relaxation"
            assert num(r["statistical_gap"]) == pytest.approx((min(statistical) - num(r["value"])) / min(statistical))


def test_a_plan_methods_value_is_its_plans_exact_expectation(lossy_report, nets):
    out, rows = lossy_report
    for name in ("tiny1", "tiny2"):
        inst = instance_mod.load(nets / f"{name}.json")
        for method in ("dp", "greedy"):
            r = voiopt.load_result(out / "results" / f"{name}__{method}.json")
            row = next(x for x in rows if (x["instance"], x["method"]) == (name, method))
            assert row["evaluation"] == "exact"
            assert num(row["value"]) == pytest.approx(voiopt.expected_metrics(inst, r.plan)[OBJECTIVE], rel=1e-12)


def test_the_summary_says_how_each_value_was_computed_and_which_gaps_are_statistical(lossy_report):
    out, rows = lossy_report
    md = (out / "summary.md").read_text()
    assert "## Lossy instances" in md
    mc = next(r for r in rows if r["evaluation"] == "monte-carlo")
    line = next(x for x in md.splitlines() if x.startswith(f"| {mc['instance']} | {mc['method']} | {mc['seed'] or '-'} |"))
    half = (num(mc["value_ci_high"]) - num(mc["value_ci_low"])) / 2
    assert f"± {half_width(half)} (monte-carlo, 300 scenarios)" in line and "(estimate, to exact)" in line
    assert "(statistical, to information-relaxation)" in line
    pdp = next(x for x in md.splitlines() if x.startswith("| tiny1 | policy-dp |"))
    assert "(exact)" in pdp and "(proven, to exact)" in pdp
    assert "tiny3" not in md.split("## Lossy instances")[1]
    assert (out / "gaps.png").stat().st_size > 1000


def _result(method, value, bound, kind, evaluation=Evaluation.EXACT, ci=None):
    return Result("i", method, voiopt.objectives.get(OBJECTIVE), Status.FEASIBLE, value, bound, None, 0.0, None, None,
                  {}, evaluation, None if ci is None else 100, ci, kind)


def test_an_estimate_past_the_bound_has_a_negative_gap_and_a_statistical_bound_is_never_the_headline():
    exact = _result("policy-dp", 10.0, 10.0, BoundKind.EXACT)
    lossless = _result("dp", 8.0, 10.0, BoundKind.LOSSLESS)  # the same number as the exact bound: exact wins
    ir = _result("replan", 9.0, 9.5, BoundKind.INFORMATION_RELAXATION)  # statistical, and below the optimum
    mc = _result("qlearning", 10.2, 12.0, BoundKind.LOSSLESS, Evaluation.MONTE_CARLO, (9.9, 10.5))
    group = [exact, lossless, ir, mc]
    rows = report.gap_rows(group, OBJECTIVE)
    assert {(r["best_bound"], r["best_bound_kind"]) for r in rows} == {(10.0, BoundKind.EXACT)}
    f = lossy_fields(mc, group, voiopt.objectives.get(OBJECTIVE))
    assert f["gap"] == pytest.approx(-0.02) and (f["gap_ci_low"], f["gap_ci_high"]) == pytest.approx((-0.05, 0.01))
    assert f["statistical_bound"] == 9.5 and f["statistical_gap"] == pytest.approx((9.5 - 10.2) / 9.5)
    assert rows[1]["gap"] == pytest.approx(0.2) and rows[1]["bound_kind"] == BoundKind.LOSSLESS


@pytest.mark.parametrize(("flag", "value"), [("--samples", "1"), ("--samples", "0"), ("--ir-samples", "1"),
                                             ("--ir-samples", "-3")])
def test_bad_sample_counts_exit_2_before_any_work(capsys, tmp_path, nets, flag, value):
    assert main(["gap-report", str(nets), "--methods", "policy-dp", flag, value, "-o", str(tmp_path / "r")]) == 2
    assert flag in capsys.readouterr().err and not (tmp_path / "r").exists()
