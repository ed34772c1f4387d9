"""voiopt show and plot --animate without a browser: the page is self-contained, its embedded
data is the simulator's to the last bit, bad input is one line with exit status 2, and an
animation has one frame a slot. (In a real browser: tests/test_viewer_browser.py.)"""

from __future__ import annotations

import json
import random
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import field_instances, fleet_instances, run_cli, tiny_instances
from hypothesis import given, settings
from hypothesis import strategies as st
from oracles import model_oracle as oracle

import voiopt
from voiopt.core.plan import Plan
from voiopt.viewer import page
from voiopt.viewer.story import Entry, story

ROOT = Path(__file__).resolve().parent.parent
CASE = ROOT / "instances" / "case-study.json"
CASE_PLAN = ROOT / "instances" / "case-study.plan.json"
CASES = tiny_instances(8) + field_instances(8) + fleet_instances(6)




def one_line_error(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def embedded(html: str) -> dict:
    m = re.search(r'<script type="application/json" id="voiopt-data">(.*?)</script>', html, re.S)
    return json.loads(m.group(1))


def _save(tmp_path, inst, method, name):
    result = voiopt.solve(inst, method=method)
    result.save(tmp_path / name)
    return result


@settings(max_examples=25, deadline=None)
@given(k=st.integers(0, len(CASES) - 1), seed=st.integers(0, 2**16))
def test_the_story_is_the_simulation_of_any_legal_plan(k, seed):
    """For random legal plans (the oracle's walks) the page's data, once through JSON, equals
    the simulator's trajectory bit for bit, and the oracle's metrics."""
    inst = CASES[k]
    d = inst.to_dict()
    plan_dict = oracle.random_legal_plan(d, random.Random(seed))
    plan = Plan.from_dict(plan_dict)
    data = json.loads(json.dumps(story(inst, [Entry("p", plan, "mean-min-voi")])))
    traj = voiopt.simulate(inst, plan)
    r = data["results"][0]
    assert r["aoi"] == traj.aoi.tolist()
    np.testing.assert_array_equal(np.array(r["voi"], dtype=float), traj.voi)
    for j, robot in enumerate(plan.robots):
        assert list(zip(r["x"][j], r["y"][j], strict=True)) == [tuple(map(float, p)) for p in robot.positions]
        assert r["u"][j] == [-1 if u is None else u for u in robot.schedule]
    want = oracle.simulate(d, plan_dict)
    for name, v in want.items():
        assert r["simulated"][name] == pytest.approx(v, rel=1e-12)


def test_the_page_is_self_contained(capsys, tmp_path):
    out = tmp_path / "cs.html"
    assert run_cli(capsys, "show", CASE_PLAN, "--instance", CASE, "-o", out)[0] == 0
    html = out.read_text()
    assert not re.search(r"https?:|//[a-z0-9.-]+\.[a-z]{2,}/|@import|\burl\(", html, re.I)
    assert not re.search(r"<(script|img|link|iframe)[^>]*\b(src|href)\s*=", html, re.I)
    assert embedded(html)["instance"]["name"] == "case-study"


def test_results_side_by_side_and_gap_labels(capsys, tmp_path):
    inst = voiopt.load(CASE)
    dp = _save(tmp_path, inst, "dp", "dp.json")
    _save(tmp_path, inst, "shortest-path", "sp.json")
    raw = json.loads((tmp_path / "dp.json").read_text())
    raw["bound_kind"] = "information-relaxation"  # a statistical bound (MODEL.md section 11)
    (tmp_path / "ir.json").write_text(json.dumps(raw))
    code, out, _ = run_cli(capsys, "show", tmp_path / "dp.json", tmp_path / "sp.json", tmp_path / "ir.json", "--instance", CASE,
                       "-o", tmp_path / "p.html")
    assert code == 0 and "wrote" in out
    rs = embedded((tmp_path / "p.html").read_text())["results"]
    assert [r["method"] for r in rs] == ["dp", "shortest-path", "dp"]
    assert [r["gapKind"] for r in rs] == ["proven", "proven", "statistical"]
    assert rs[0]["value"] == dp.value and rs[0]["status"] == dp.status


def test_a_monte_carlo_value_is_labelled_with_its_interval_and_samples(capsys, tmp_path):
    """MODEL.md section 11's fields are carried to the page as the result states them."""
    inst = voiopt.load(CASE)
    _save(tmp_path, inst, "shortest-path", "sp.json")
    raw = json.loads((tmp_path / "sp.json").read_text())
    raw.update(evaluation="monte-carlo", samples=500, value_ci=[raw["value"] * 0.9, raw["value"] * 1.1])
    (tmp_path / "mc.json").write_text(json.dumps(raw))
    assert run_cli(capsys, "show", tmp_path / "mc.json", "--instance", CASE, "-o", tmp_path / "p.html")[0] == 0
    (r,) = embedded((tmp_path / "p.html").read_text())["results"]
    assert (r["evaluation"], r["samples"], r["valueCi"]) == ("monte-carlo", 500, raw["value_ci"])
    assert r["run"] is None  # a lossless instance: nothing sampled


def test_a_result_text_cannot_end_the_script():
    """A result's method is any string: "</script>" in it does not end the page's data."""
    bad = "</script><script>alert(1)</script>"
    inst = voiopt.load(CASE)
    html = page.render(story(inst, [Entry(bad, voiopt.load_plan(CASE_PLAN), "mean-min-voi", method=bad)]))
    assert html.count("</script>") == 2  # the data's and the code's own
    assert embedded(html)["results"][0]["method"] == bad


def test_bad_input_is_one_line_and_exit_2(capsys, tmp_path):
    inst = voiopt.load(CASE)
    _save(tmp_path, inst, "shortest-path", "cs.json")
    fleet = voiopt.load(ROOT / "instances" / "fleet.json")
    _save(tmp_path, fleet, "greedy", "fleet.json")
    (tmp_path / "broken.json").write_text("{not json")
    none = json.loads((tmp_path / "cs.json").read_text())
    none.update(plan=None, status="infeasible", value=None, metrics=None)
    (tmp_path / "none.json").write_text(json.dumps(none))
    edited = json.loads((tmp_path / "cs.json").read_text())
    edited["value"] *= 2
    (tmp_path / "edited.json").write_text(json.dumps(edited))
    cases = [
        ((tmp_path / "cs.json", tmp_path / "fleet.json", "--instance", CASE), "is for instance"),
        ((tmp_path / "broken.json", "--instance", CASE), "broken.json: invalid JSON"),
        ((tmp_path / "missing.json", "--instance", CASE), "missing.json: no such file"),
        ((tmp_path / "none.json", "--instance", CASE), "has no plan to show"),
        ((tmp_path / "edited.json", "--instance", CASE), "does not give what the result says"),
        ((CASE_PLAN,), "--instance: give the instance"),
        ((CASE,), "an instance, not a plan"),
        ((tmp_path / "cs.json", "--instance", CASE, "-o", tmp_path / "no" / "p.html"), "does not exist"),
    ]
    cases.append(((tmp_path / "cs.json", "--instance", CASE, "--seed", "-1"), "--seed: must be an integer >= 0"))
    for argv, message in cases:
        code, _, err = run_cli(capsys, "show", *argv)
        assert code == 2 and message in one_line_error(err), (argv, err)
    assert not list(tmp_path.glob("*.html"))


def test_the_default_page_is_named_after_the_first_file(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, _ = run_cli(capsys, "show", CASE_PLAN, "--instance", CASE)
    assert code == 0 and (tmp_path / "case-study.plan.html").is_file() and "case-study.plan.html" in out


def test_animate_writes_a_gif_of_t_frames(capsys, tmp_path):
    from PIL import Image

    out = tmp_path / "cs.gif"
    code, text, _ = run_cli(capsys, "plot", CASE_PLAN, "--instance", CASE, "--animate", "-o", out)
    assert code == 0 and "wrote" in text
    with Image.open(out) as gif:
        assert gif.n_frames == voiopt.load(CASE).horizon
        frames = []
        for t in range(gif.n_frames):
            gif.seek(t)
            frames.append(np.asarray(gif.convert("RGB")))
    assert all((a != b).any() for a, b in zip(frames, frames[1:], strict=False))  # each slot its own picture
    assert [p.name for p in tmp_path.iterdir()] == ["cs.gif"]  # no temporary file left


def test_each_frame_shows_its_slot_number():
    from voiopt.viewer.frames import Painter, slots_of

    inst = voiopt.load(CASE)
    painter = Painter(inst)
    for slot in slots_of(voiopt.simulate(inst, voiopt.load_plan(CASE_PLAN)), inst):
        painter.draw(slot)
        assert f"slot t = {slot.t} " in painter.heading.get_text()


def test_animate_bad_output_is_one_line(capsys, tmp_path, monkeypatch):
    code, _, err = run_cli(capsys, "plot", CASE_PLAN, "--instance", CASE, "--animate", "-o", tmp_path / "a.png")
    assert code == 2 and "an animation is written as .gif or .mp4" in one_line_error(err)
    monkeypatch.setattr("shutil.which", lambda name: None)
    code, _, err = run_cli(capsys, "plot", CASE_PLAN, "--instance", CASE, "--animate", "-o", tmp_path / "a.mp4")
    assert code == 2 and "needs ffmpeg, which is not installed here" in one_line_error(err)
    assert not list(tmp_path.iterdir())


def test_plot_without_animate_is_unchanged(capsys, tmp_path):
    assert run_cli(capsys, "plot", CASE_PLAN, "--instance", CASE, "-o", tmp_path / "a.png")[0] == 0
    assert (tmp_path / "a.png").stat().st_size > 1000


def test_a_policy_result_is_shown_as_one_sampled_run_with_its_failures(capsys, tmp_path):
    """Lossy links: a policy result (no plan; its policy saved beside it) is one run of the policy
    in scenario 0 of the seed: the uploads it scheduled are drawn, those whose U(t, i) was not
    below p_i(d) are marked failed, and the ages and values are the simulator's of the uploads
    that succeeded. A plan result on the same instance is sampled with the same seed."""
    from voiopt.core.scenarios import sample_scenarios

    lossy = voiopt.load(CASE).to_dict() | {"links": {"model": "bernoulli", "success": 0.6}}
    lossy["horizon"] = 6
    (tmp_path / "case-study.json").write_text(json.dumps(lossy))
    out = tmp_path / "pol.json"
    assert run_cli(capsys, "solve", tmp_path / "case-study.json", "--method", "policy-dp", "-o", out, "--quiet")[0] == 0
    assert (tmp_path / "pol.policy.json").exists()
    assert run_cli(capsys, "show", out, "--seed", "0", "-o", tmp_path / "p.html")[0] == 0
    (r,) = embedded((tmp_path / "p.html").read_text())["results"]
    inst = voiopt.load(tmp_path / "case-study.json")
    u = sample_scenarios(inst, 1, 0)[0]
    xy = list(zip(r["x"][0], r["y"][0], strict=True))
    d = [[np.hypot(x - s.position[0], y - s.position[1]) for s in inst.sensors] for x, y in xy]
    sched = r["u"][0]
    failed = [s >= 0 and not u[t, s] < 0.6 for t, s in enumerate(sched)]
    assert any(failed) and any(s >= 0 and not f for s, f in zip(sched, failed, strict=True))  # both kinds occur
    assert r["run"] == {"seed": 0, "failed": [failed]} and r["method"] == "policy-dp"
    assert all(d[t][s] <= inst.channel.d_th + 1e-9 for t, s in enumerate(sched) if s >= 0)
    realised = Plan(tuple(xy), tuple(None if s < 0 or f else s for s, f in zip(sched, failed, strict=True)))
    traj = voiopt.simulate(inst, realised)  # the simulator takes the realised uploads as they are
    assert r["aoi"] == traj.aoi.tolist() and r["simulated"]["mean-min-voi"] == traj.metrics["mean-min-voi"]
