"""The command line under lossy links (MODEL.md section 11): ``generate --links``, ``evaluate``
reporting a plan's exact expected objectives, labelled, and ``solve`` on a lossy instance."""

from __future__ import annotations

import json

import pytest
from conftest import ROOT, one_line_error, run_cli

import voiopt
from voiopt.cli.lossy import parse_links
from voiopt.cli.main import main
from voiopt.core.expectation import expected_metrics
from voiopt.errors import OptionError

CASE = str(ROOT / "instances" / "case-study.json")
PLAN = str(ROOT / "instances" / "case-study.plan.json")




def test_generate_links_adds_them_and_changes_nothing_else(capsys):
    code, plain, _ = run_cli(capsys, "generate", "--sensors", "3", "--seed", "4")
    code2, lossy, _ = run_cli(capsys, "generate", "--sensors", "3", "--seed", "4", "--links", "rayleigh:21.5")
    assert code == code2 == 0
    a, b = json.loads(plain), json.loads(lossy)
    assert b.pop("links") == {"model": "rayleigh", "snr_threshold_db": 21.5}
    assert a == b
    code, out, _ = run_cli(capsys, "generate", "--preset", "factory", "--sensors", "2", "--links", "bernoulli:0.9")
    assert code == 0 and json.loads(out)["links"] == {"model": "bernoulli", "success": 0.9}


@pytest.mark.parametrize("text", ["bernoulli:0", "bernoulli:1.01", "bernoulli:nan", "bernoulli", "rayleigh:inf",
                                  "rayleigh:", "gilbert:0.5", "0.5"])
def test_bad_links_option_is_one_line_exit_2(capsys, text):
    with pytest.raises(SystemExit) as e:
        main(["generate", "--links", text])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--links" in err and text in err
    with pytest.raises(OptionError, match="^--links: "):
        parse_links(text)


def test_evaluate_reports_exact_expectations_labelled(capsys, tmp_path):
    inst = voiopt.load(CASE)
    path = tmp_path / "lossy.json"
    path.write_text(json.dumps(inst.to_dict() | {"links": {"model": "bernoulli", "success": 0.5}}))
    code, out, _ = run_cli(capsys, "evaluate", str(path), PLAN, "--json")
    assert code == 0
    d = json.loads(out)
    want = expected_metrics(voiopt.load(path), voiopt.load_plan(PLAN))
    assert d["metrics"] == want and d["expected"] is True and d["evaluation"] == "exact"
    assert d["metrics"] != voiopt.evaluate(inst, voiopt.load_plan(PLAN))
    code, out, _ = run_cli(capsys, "evaluate", str(path), PLAN)
    assert code == 0 and "expected" in out and "exact" in out


def test_evaluate_without_losses_is_unchanged(capsys, tmp_path):
    code, out, _ = run_cli(capsys, "evaluate", CASE, PLAN, "--json")
    d = json.loads(out)
    assert set(d) == {"instance", "metrics"} and d["metrics"] == voiopt.evaluate(voiopt.load(CASE), voiopt.load_plan(PLAN))
    path = tmp_path / "ones.json"
    path.write_text(json.dumps(voiopt.load(CASE).to_dict() | {"links": {"model": "bernoulli", "success": 1}}))
    code, out2, _ = run_cli(capsys, "evaluate", str(path), PLAN, "--json")
    assert json.loads(out2) == d


def test_solve_on_a_lossy_instance_writes_the_labelled_result(capsys, tmp_path):
    path = tmp_path / "lossy.json"
    path.write_text(json.dumps(voiopt.load(CASE).to_dict() | {"links": {"model": "rayleigh", "snr_threshold_db": 28}}))
    code, out, _ = run_cli(capsys, "solve", str(path), "--method", "greedy", "-o", str(tmp_path / "r.json"))
    assert code == 0 and "expected, exact" in out and "expected objectives over the upload outcomes" in out
    r = json.loads((tmp_path / "r.json").read_text())
    assert r["evaluation"] == "exact" and r["status"] == "feasible"
    assert r["metrics"] == expected_metrics(voiopt.load(path), voiopt.Plan.from_dict(r["plan"]))


def test_plot_of_a_lossy_result_checks_its_expected_metrics(capsys, tmp_path):
    path = tmp_path / "lossy.json"
    path.write_text(json.dumps(voiopt.load(CASE).to_dict() | {"links": {"model": "bernoulli", "success": 0.6}}))
    assert run_cli(capsys, "solve", str(path), "--method", "greedy", "-o", str(tmp_path / "r.json"))[0] == 0
    code, out, _ = run_cli(capsys, "plot", str(tmp_path / "r.json"), "--instance", str(path), "-o", str(tmp_path / "r.png"))
    assert code == 0 and (tmp_path / "r.png").stat().st_size > 0
    code, _, err = run_cli(capsys, "plot", str(tmp_path / "r.json"), "--instance", CASE, "-o", str(tmp_path / "s.png"))
    assert code == 2 and "does not give what the result says" in err  # the lossless instance: other values


def _tiny_file(tmp_path, p=0.5, T=5):
    from oracles.expectimax import tiny

    path = tmp_path / "tiny.json"
    path.write_text(json.dumps(tiny(2, 3, T, {"model": "bernoulli", "success": p})))
    return str(path)


def test_solve_labels_a_monte_carlo_value_its_bound_and_its_gap(capsys, tmp_path):
    """A Monte Carlo value is never under a title that says exact; its gap is an estimate; a
    statistical bound says so, and so does its gap."""
    path = _tiny_file(tmp_path)
    code, out, _ = run_cli(capsys, "solve", path, "--method", "qlearning", "--episodes", "2000", "--samples", "50")
    assert code == 0 and "expected, exact" in out and "(lossless, proven)" in out and "(proven)" in out
    # more states than the exact enumeration takes: Monte Carlo
    from voiopt.solvers.qlearning import lossy

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(lossy, "EXACT_STATES", 1)
        code, out, _ = run_cli(capsys, "solve", path, "--method", "qlearning", "--episodes", "2000", "--samples", "50")
    assert code == 0 and "monte-carlo, 50 scenarios" in out and "(estimate)" in out
    assert "Monte Carlo estimates over 50 scenarios" in out and "(exact, lossy links)" not in out
    code, out, _ = run_cli(capsys, "solve", path, "--method", "replan", "--ir-samples", "10")
    assert code == 0 and "(information-relaxation, statistical)" in out and "(statistical)" in out


def test_a_policy_that_meets_the_lossless_bound_is_feasible_with_a_proven_zero_gap(capsys):
    """MODEL.md 11: optimal needs an exact bound; re-planning on a lossless instance meets the
    lossless bound, a proven gap of 0, and is not called optimal."""
    code, out, _ = run_cli(capsys, "solve", CASE, "--method", "replan")
    assert code == 0 and "replan  mean-min-voi: feasible" in out and "gap 0 % (proven)" in out


@pytest.mark.parametrize("flag,value", [("--samples", "1"), ("--samples", "0"), ("--samples", "-5"),
                                         ("--ir-samples", "1"), ("--ir-samples", "-2")])
def test_scenario_counts_are_refused_before_any_work(capsys, tmp_path, flag, value):
    code, _, err = run_cli(capsys, "solve", _tiny_file(tmp_path), "--method", "qlearning", "--episodes", "1e9", flag,
                           value)
    line = one_line_error(err)
    assert code == 2 and flag.lstrip("-").replace("-", "_") in line and f"got {value}" in line
