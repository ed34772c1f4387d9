"""voiopt show and plot --animate under lossy links (MODEL.md section 11): a result is checked
against the instance it is shown on (a plan's exact expectation; a policy's instance, links
included, and its exact value), a gap says whether it is proven, an estimate or statistical,
and the animation and the plot say what they draw."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest import run_cli
from test_viewer import embedded, one_line_error

import voiopt
from voiopt.core.expectation import expected_metrics
from voiopt.experiments.lossy_gaps import gap_range
from voiopt.objectives import show_gap

ROOT = Path(__file__).resolve().parent.parent
CASE = ROOT / "instances" / "case-study.json"
BERNOULLI = {"model": "bernoulli", "success": 0.6}
RAYLEIGH = {"model": "rayleigh", "snr_threshold_db": 20.0}


def _network(folder: Path, links: dict | None, file: str = "case-study.json", horizon: int = 6) -> Path:
    """The case study (same name whatever its links, as ``generate --links`` names networks)."""
    d = voiopt.load(CASE).to_dict() | {"horizon": horizon}
    if links is not None:
        d["links"] = links
    folder.mkdir(parents=True, exist_ok=True)
    (folder / file).write_text(json.dumps(d))
    return folder / file


def _differ(a: float, b: float) -> bool:
    return abs(a - b) > 1e-6 * max(abs(a), abs(b))


def test_a_plan_result_is_checked_against_its_exact_expectation_on_the_given_instance(capsys, tmp_path):
    """The reviewer's repro: one network, two links; a plan solved on the Bernoulli one and shown
    with the Rayleigh one was drawn with the Bernoulli value labelled "exact expectation"."""
    b = _network(tmp_path / "b", BERNOULLI)
    ray = _network(tmp_path / "r", RAYLEIGH)
    lossless = _network(tmp_path / "l", None)
    result = voiopt.solve(voiopt.load(b), method="greedy")
    result.save(tmp_path / "b-greedy.json")
    plan = result.plan
    assert _differ(expected_metrics(voiopt.load(ray), plan)[result.objective], result.value)  # the repro is real
    for other in (ray, lossless):
        code, _, err = run_cli(capsys, "show", tmp_path / "b-greedy.json", "--instance", other, "-o", tmp_path / "x.html")
        line = one_line_error(err)
        assert code == 2 and "b-greedy.json: its plan on" in line and "does not give what the result says" in line
    assert "exact expectation" in line or "simulated" in line
    assert not (tmp_path / "x.html").exists()
    assert run_cli(capsys, "show", tmp_path / "b-greedy.json", "--instance", b, "-o", tmp_path / "ok.html")[0] == 0
    (r,) = embedded((tmp_path / "ok.html").read_text())["results"]
    assert (r["value"], r["evaluation"], r["kind"]) == (result.value, "exact", "plan")
    # and a lossless result is not passed off on the lossy network of its name
    voiopt.solve(voiopt.load(lossless), method="greedy").save(tmp_path / "l-greedy.json")
    code, _, err = run_cli(capsys, "show", tmp_path / "l-greedy.json", "--instance", b, "-o", tmp_path / "y.html")
    assert code == 2 and "exact expectation" in one_line_error(err)


def test_a_plan_file_on_a_lossy_instance_is_shown_with_its_exact_expectation(capsys, tmp_path):
    b = _network(tmp_path, BERNOULLI)
    plan = voiopt.solve(voiopt.load(b), method="greedy").plan
    (tmp_path / "p.json").write_text(json.dumps(plan.to_dict()))
    assert run_cli(capsys, "show", tmp_path / "p.json", "--instance", b, "-o", tmp_path / "p.html")[0] == 0
    (r,) = embedded((tmp_path / "p.html").read_text())["results"]
    assert r["value"] == expected_metrics(voiopt.load(b), plan)["mean-min-voi"] and r["evaluation"] == "exact"
    assert r["run"]["seed"] == 0


@pytest.fixture(scope="module")
def policy_result(tmp_path_factory):
    """policy-dp on the lossy case study (T = 6): an exact value, its policy saved beside it."""
    from voiopt.cli.main import main

    folder = tmp_path_factory.mktemp("policy")
    b = _network(folder, BERNOULLI)
    assert main(["solve", str(b), "--method", "policy-dp", "-o", str(folder / "pol.json"), "--quiet"]) == 0
    return folder


def test_a_policy_result_is_refused_on_an_instance_with_other_links(capsys, tmp_path, policy_result):
    ray = _network(tmp_path, RAYLEIGH)
    code, _, err = run_cli(capsys, "show", policy_result / "pol.json", "--instance", ray, "-o", tmp_path / "x.html")
    line = one_line_error(err)
    assert code == 2 and "pol.json: its policy was made for links" in line and "rayleigh" in line
    other = _network(tmp_path / "h", BERNOULLI, horizon=5)  # the same links, another horizon
    code, _, err = run_cli(capsys, "show", policy_result / "pol.json", "--instance", other, "-o", tmp_path / "x.html")
    assert code == 2 and "made for another instance" in one_line_error(err) and "horizon" in err
    assert not (tmp_path / "x.html").exists()


def test_a_policy_results_exact_value_is_computed_again(capsys, tmp_path, policy_result):
    d = json.loads((policy_result / "pol.json").read_text())
    assert d["evaluation"] == "exact" and d["solver"]["policy_file"] == "pol.policy.json"
    d["value"] *= 1.01
    d["metrics"][d["objective"]] = d["value"]
    (policy_result / "edited.json").write_text(json.dumps(d))
    code, _, err = run_cli(capsys, "show", policy_result / "edited.json", "-o", tmp_path / "x.html")
    assert code == 2 and "its policy on" in one_line_error(err) and "exact)" in err
    assert run_cli(capsys, "show", policy_result / "pol.json", "-o", tmp_path / "ok.html")[0] == 0
    (r,) = embedded((tmp_path / "ok.html").read_text())["results"]
    assert r["kind"] == "policy" and r["gapKind"] == "proven"


def test_a_monte_carlo_value_has_an_estimated_gap_never_a_proven_one(capsys, tmp_path, policy_result):
    """gap-report's words: to a proven bound, an exact value's gap is proven, a Monte Carlo
    value's an estimate (with the range its CI implies); to an information-relaxation bound,
    statistical (the reviewer saw "gap 80.2 % proven" for a Q-learning estimate)."""
    d = json.loads((policy_result / "pol.json").read_text())
    v = d["value"]
    mc = d | {"evaluation": "monte-carlo", "samples": 500, "value_ci": [0.9 * v, 1.02 * v], "bound": 1.3 * v,
              "bound_kind": "lossless", "gap": 0.3 / 1.3, "status": "feasible"}
    ir = mc | {"bound_kind": "information-relaxation", "bound_samples": 100, "bound_confidence": 0.95}
    (policy_result / "mc.json").write_text(json.dumps(mc))
    (policy_result / "ir.json").write_text(json.dumps(ir))
    code, _, err = run_cli(capsys, "show", policy_result / "mc.json", policy_result / "ir.json",
                           "-o", tmp_path / "p.html")
    assert code == 0, err
    r_mc, r_ir = embedded((tmp_path / "p.html").read_text())["results"]
    assert (r_mc["gapKind"], r_ir["gapKind"]) == ("estimate", "statistical")
    low, high = gap_range(d["objective"], (0.9 * v, 1.02 * v), 1.3 * v)
    assert r_mc["gapRange"] == [show_gap(low), show_gap(high)] and low < mc["gap"] < high


def _gif_frames(path: Path):
    import numpy as np
    from PIL import Image

    with Image.open(path) as gif:
        out = []
        for t in range(gif.n_frames):
            gif.seek(t)
            out.append(np.asarray(gif.convert("RGB")))
    return out


def test_plot_of_a_policy_result_is_one_line(capsys, tmp_path, policy_result):
    for name in ("a.gif", "a.png"):
        argv = ["plot", policy_result / "pol.json", "-o", tmp_path / name] + (["--animate"] if name.endswith(".gif") else [])
        code, _, err = run_cli(capsys, *argv)
        assert code == 2 and "voiopt show draws a sampled run" in one_line_error(err), name
        assert not (tmp_path / name).exists()


def test_a_lossy_page_is_the_same_for_the_same_seed(capsys, tmp_path, policy_result):
    """The sampled run is scenario 0 of the seed: the same seed writes the same bytes (in
    another process too: nothing hangs on hash order or the clock); another seed another run."""
    import subprocess
    import sys

    argv = ["show", policy_result / "pol.json", "--seed", "3", "-o"]
    assert run_cli(capsys, *argv, tmp_path / "a.html")[0] == 0
    env = {"PYTHONPATH": str(ROOT), "PYTHONHASHSEED": "12345", "PATH": "/usr/bin:/bin"}
    subprocess.run([sys.executable, "-m", "voiopt", *map(str, argv), str(tmp_path / "b.html")], check=True, env=env,
                   capture_output=True)
    assert (tmp_path / "a.html").read_bytes() == (tmp_path / "b.html").read_bytes()
    runs = set()
    for seed in range(6):
        assert run_cli(capsys, "show", policy_result / "pol.json", "--seed", seed, "-o", tmp_path / "c.html")[0] == 0
        (r,) = embedded((tmp_path / "c.html").read_text())["results"]
        assert r["run"]["seed"] == seed
        runs.add(json.dumps(r["run"]["failed"]))
    assert len(runs) > 1


def test_animate_and_plot_say_that_every_upload_succeeds_on_a_lossy_instance(capsys, tmp_path, monkeypatch):
    """The frames of a plan on lossy links are the run in which every upload succeeds: the
    frame says so (a caption), which a lossless instance's frame does not carry."""
    from voiopt.viewer.frames import Painter, slots_of
    from voiopt.viewer.story import lossy_caption

    b, lossless = voiopt.load(_network(tmp_path / "b", BERNOULLI)), voiopt.load(_network(tmp_path / "l", None))
    assert "every upload succeeds" in lossy_caption(b) and "voiopt show draws a sampled run" in lossy_caption(b)
    assert lossy_caption(lossless) == ""
    plan = voiopt.solve(b, method="greedy").plan
    painter = Painter(b, "greedy", caption=lossy_caption(b))
    painter.draw(next(slots_of(voiopt.simulate(b, plan), b)))
    texts = [t.get_text() for t in painter.figure.texts]
    assert any("every upload succeeds" in t for t in texts)
    assert not Painter(lossless, "greedy", caption=lossy_caption(lossless)).figure.texts
    # the command passes it on: a GIF of the lossy network is captioned, the lossless one's not
    import voiopt.viewer.animate as animate_mod

    seen = []

    class Recording(Painter):
        def __init__(self, instance, title="", log_range=None, caption=""):
            seen.append(caption)
            super().__init__(instance, title, log_range, caption)

    monkeypatch.setattr(animate_mod, "Painter", Recording)
    for inst, name in ((b, "b"), (lossless, "l")):
        (tmp_path / f"{name}-p.json").write_text(json.dumps(plan.to_dict()))
        code, _, err = run_cli(capsys, "plot", tmp_path / f"{name}-p.json", "--instance", tmp_path / name / "case-study.json",
                               "--animate", "-o", tmp_path / f"{name}.gif")
        assert code == 0, err
        assert len(_gif_frames(tmp_path / f"{name}.gif")) == inst.horizon
    assert seen == [lossy_caption(b), ""]


def test_the_static_plot_of_a_lossy_plan_says_its_uploads_may_fail(tmp_path, monkeypatch):
    import voiopt.experiments.plots as plots

    titles = []
    monkeypatch.setattr(plots, "save_figure", lambda fig, path: titles.append(fig.axes[0].get_title()))
    for links, name in ((BERNOULLI, "b"), (None, "l")):
        inst = voiopt.load(_network(tmp_path / name, links))
        result = voiopt.solve(inst, method="greedy")
        plots.plot_result(result, inst, tmp_path / "x.png")
        plots.plot_plan(inst, result.plan, tmp_path / "x.png", "p.json")
    assert all("each may fail" in t and "voiopt show draws a sampled run" in t for t in titles[:2])
    assert not any("may fail" in t for t in titles[2:])
