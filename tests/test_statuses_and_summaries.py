"""Statuses and summaries say the same thing everywhere (issue 47, item 7)."""

from __future__ import annotations

import contextlib
import json

from test_refusals import _corridor

import voiopt
from voiopt.core.result import Result
from voiopt.experiments import demo, gaps
from voiopt.grid import joint
from voiopt.networks.generate import case_study
from voiopt.solvers.qlearning import solver as qsolver


def test_a_fleets_milp_stopped_by_its_time_limit_before_any_plan_says_time_limit(tmp_path, monkeypatch):
    """Three robots the walker cannot route (undecided at load time: the pairs' proof is
    switched off) stopped milp before its first plan: it said error, with HiGHS's or greedy's
    words; the limit stopped it, and the status says so."""
    monkeypatch.setattr(joint, "pairs_possible", lambda *a: None)
    inst = voiopt.load(_corridor(tmp_path))
    r = voiopt.solve(inst, "milp", "max-aoi", time_limit=1.0)
    assert r.status in ("time_limit", "infeasible"), (r.status, r.solver.get("note"))
    if r.status == "time_limit":
        assert r.plan is None and r.value is None and "stopped before any legal joint plan" in r.solver["note"]
        again = Result.from_dict(json.loads(json.dumps(r.to_dict())))
        assert again.status == "time_limit" and again.plan is None


def _run(status, error=None, gap_value=None):
    solver = {} if error is None else {"error": error}
    return {"instance": "a", "method": "greedy", "seed": None, "status": status, "gap": gap_value, "runtime_s": 0.1,
            "cause": gaps.cause(Result("a", "greedy", "max-aoi", status, None, None, None, 0.1, None, None, solver))}


def test_the_gap_report_shows_plain_messages_and_counts_proofs_as_proven_optimal():
    rows = [_run("error", "OptionError: --episodes: not an option of method 'greedy'"),
            _run("error", "RuntimeError: HiGHS crashed"), _run("feasible", gap_value=0.0)]
    assert rows[0]["cause"] == "--episodes: not an option of method 'greedy'"
    assert rows[1]["cause"] == "RuntimeError: HiGHS crashed"  # a fault, not a bad input: its kind stays
    md = gaps.summary_markdown(gaps.summarise(rows, ["greedy"]), "max-aoi", 1, rows=rows)
    header = next(line for line in md.splitlines() if line.startswith("| method"))
    assert "| proven optimal |" in header and "| optimal |" not in header
    assert "OptionError" not in md


def test_the_demo_rounds_its_closing_gaps_as_its_table_and_names_a_command_that_runs(monkeypatch):
    assert demo.percent(0.0002) == "0.02 %" == demo.percent(0.00020000001)
    monkeypatch.setattr(demo.shutil, "which", lambda name: None)  # make demo: voiopt is in .venv/bin, not on PATH
    assert demo.command().endswith(" -m voiopt")


def test_the_bit_per_hz_runs_progress_bars_say_so(monkeypatch):
    labels = []

    class Bar:
        console = None

        def add_task(self, label, **k):
            labels.append(label)

        def update(self, *a, **k):
            pass

    monkeypatch.setattr(qsolver, "progress_bar", lambda enabled, *c: contextlib.nullcontext(Bar()))
    for units in ("bit/s", "bit/s/Hz"):
        voiopt.solve(case_study(), "qlearning", episodes=20, reward_units=units, progress=True)
    voiopt.solve(case_study(), "aoi-qlearning", episodes=20, progress=True)
    assert labels == ["qlearning", "qlearning bit/s/Hz", "aoi-qlearning"]
