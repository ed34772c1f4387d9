"""VoI-Lib: the frozen instances, their certificates, and scoring a submitted result."""

from __future__ import annotations

import json

import pytest
from conftest import run_cli
from oracles import model_oracle as oracle
from test_cli import one_line_error

import voiopt
from voiopt.core.result import Result
from voiopt.errors import OptionError, VoioptError
from voiopt.networks.generate import case_study, case_study_plan
from voiopt.objectives import OBJECTIVES
from voiopt.voilib import library as voilib

LIB = voilib.instances()
CERTS = voilib.certificates()


def test_the_frozen_instances_are_the_ladder():
    """The shipped files are exactly what the ladder draws: nothing edited by hand, and a
    change of the generator that would change them is caught here."""
    assert len(LIB) >= 30
    drawn = {inst.name: inst for inst in voilib.ladder()}
    assert list(drawn) == sorted(drawn) or set(drawn) == set(LIB)
    assert set(drawn) == set(LIB)
    for name, inst in LIB.items():
        assert voilib.instance_hash(drawn[name]) == voilib.instance_hash(inst), name
        oracle.check_instance({k: v for k, v in inst.to_dict().items() if k != "links"})  # the oracle admits
        # every instance (its network: the oracle is of MODEL.md sections 1-10; links are test_voilib_lossy's)
    rules = [voilib.describe(i)["rules"] for i in LIB.values()]
    assert sum(r != "-" for r in rules) >= 6  # floors with obstacles, a dock and a budget


def test_every_instance_and_objective_is_certified():
    assert CERTS["version"] == voilib.VERSION
    assert set(CERTS["instances"]) == set(LIB)
    for name, entry in CERTS["instances"].items():
        assert entry["sha256"] == voilib.instance_hash(LIB[name])
        assert set(entry["certificates"]) == set(OBJECTIVES)


@pytest.mark.parametrize("name", sorted(n for n, i in LIB.items() if i.links is None))  # lossy: test_voilib_lossy
def test_every_certificate_resimulates_to_its_value(name):
    inst = LIB[name]
    for objective, cert in CERTS["instances"][name]["certificates"].items():
        metrics = voiopt.evaluate(inst, cert["plan"])
        assert metrics[objective] == cert["value"], (name, objective)
        assert cert["instance_sha256"] == voilib.instance_hash(inst)
        assert cert["status"] in ("optimal", "bounded")
        if cert["status"] == "optimal":
            assert cert["bound"] == cert["value"]
            proofs = [m for m, c in cert["checks"].items() if c["status"] == "optimal"]
            assert proofs, (name, objective)
        else:  # the optimum lies between the plan and the bound
            assert voiopt.objectives.better(objective, cert["bound"], cert["value"])
        both = [c for c in cert["checks"].values() if c["status"] == "optimal"]
        for c in both:  # two proofs agree (certify refuses otherwise)
            assert voiopt.objectives.gap(c["value"], cert["value"]) <= 1e-6


def test_paper_scale_certificates_are_cross_checked_by_both_methods():
    """At the paper's scale every objective is proved, and the bottleneck objectives by both
    dp and the MILP (the MILP's mean objectives may run into certify's time limit)."""
    paper = [n for n in LIB if n.startswith(("paper-n3", "paper-n4", "case-study"))]
    for name in paper:
        for objective, cert in CERTS["instances"][name]["certificates"].items():
            assert cert["status"] == "optimal"
            proofs = {m for m, c in cert["checks"].items() if c["status"] == "optimal"}
            if objective in ("min-voi", "max-aoi"):
                assert proofs == {"dp", "milp"}, (name, objective)


def test_certificate_of_refuses_disagreeing_proofs():
    inst = LIB["paper-n3-t10-000"]
    r = voiopt.solve(inst, "dp", "max-aoi")
    forged = Result.from_dict({**r.to_dict(), "method": "milp", "value": r.value + 1, "bound": r.value + 1})
    with pytest.raises(VoioptError, match="the exact methods disagree"):
        voilib.certificate_of(inst, "max-aoi", [r, forged])


def _submission(name, objective, method="greedy"):
    r = voiopt.solve(LIB[name], method, objective)
    return r.to_dict()


def test_score_accepts_an_honest_result_with_its_gap():
    sub = _submission("paper-n4-t30-000", "mean-min-voi")
    row = voilib.score(sub)
    cert = CERTS["instances"]["paper-n4-t30-000"]["certificates"]["mean-min-voi"]
    assert row["value"] == sub["value"]
    assert row["gap_to_bound"] == pytest.approx(abs(cert["bound"] - sub["value"]) / abs(cert["bound"]))
    by_hash = {k: v for k, v in sub.items() if k != "instance"}
    by_hash["instance_sha256"] = voilib.instance_hash(LIB["paper-n4-t30-000"])
    assert voilib.score(by_hash)["instance"] == "paper-n4-t30-000"


def test_score_rejects_a_forged_value():
    sub = _submission("paper-n4-t30-000", "mean-min-voi")
    sub["value"] *= 1.01
    with pytest.raises(OptionError, match="is not what its plan gives"):
        voilib.score(sub)


@pytest.mark.parametrize("stated", ["1e400", "-1e400", "1" + "0" * 400])
def test_score_rejects_a_value_that_is_not_finite(tmp_path, capsys, stated):
    """1e400 reads as infinity, and |inf - value| <= 1e-9 * inf held: a review scored it."""
    sub = _submission("paper-n4-t30-000", "mean-min-voi")
    path = tmp_path / "inf.json"
    path.write_text(json.dumps({**sub, "value": 0.5}).replace('"value": 0.5', f'"value": {stated}'))
    good = tmp_path / "good.json"
    good.write_text(json.dumps(sub))
    code, out, err = run_cli(capsys, "bench", "score", str(path), str(good))  # the good one still scored
    assert code == 2 and "value: must be a finite number" in one_line_error(err) and "paper-n4-t30-000" in out
    code, _, err = run_cli(capsys, "bench", "score", str(path))
    assert code == 2 and "value: must be a finite number" in one_line_error(err)


def test_score_gives_the_certificate_as_numbers():
    sub = _submission("paper-n4-t30-000", "mean-min-voi")
    row = voilib.score(sub)
    cert = CERTS["instances"]["paper-n4-t30-000"]["certificates"]["mean-min-voi"]
    assert row["result"] is None and (row["certified_status"], row["certified_value"], row["certified_bound"]) == (
        cert["status"], cert["value"], cert["bound"])


def test_a_result_solved_on_an_edited_copy_is_told_so():
    edited = LIB["paper-n4-t30-000"].to_dict()
    edited["sensors"][0]["rho"] = 0.5 if edited["sensors"][0]["rho"] != 0.5 else 0.6
    r = voiopt.solve(voiopt.core.instance.from_dict(edited), method="greedy", objective="mean-min-voi").to_dict()
    with pytest.raises(OptionError, match="is not what its plan gives on VoI-Lib's paper-n4-t30-000 .*another instance"):
        voilib.score(r)
    r["instance_sha256"] = voilib.instance_hash(LIB["paper-n4-t30-000"])  # named exactly: the plain message
    with pytest.raises(OptionError, match=r"by the simulator\): rejected$"):
        voilib.score(r)


def test_the_gap_to_the_best_known_value_is_negative_for_a_better_plan():
    """A plan better than the best known one (possible where a certificate is open) must not
    read as a plan behind it: |best - value| alone has no sign."""
    assert voilib.behind("mean-min-voi", 11.0, 10.0) == pytest.approx(-0.1)
    assert voilib.behind("mean-min-voi", 9.0, 10.0) == pytest.approx(0.1)
    assert voilib.behind("max-aoi", 9.0, 10.0) == pytest.approx(-0.1)
    assert voilib.behind("mean-max-aoi", 11.0, 10.0) == pytest.approx(0.1)
    sub = _submission("paper-n4-t30-000", "mean-min-voi")
    assert voilib.score(sub)["gap_to_best"] >= 0


def test_a_submitters_own_fields_are_kept_out_of_the_way():
    sub = {**_submission("paper-n4-t30-000", "mean-min-voi"), "seed": 3, "notes": "PPO, 1e6 steps", "method": "ppo"}
    assert voilib.score(sub)["value"] == sub["value"]
    own = ("instance_name", "instance_id", "instance_file", "instance_hash", "objective_value", "objectives", "values",
           "plans", "author", "planner", "metric", "evaluated_value", "plot", "distance", "valid")  # 9 were refused
    assert voilib.score({**sub, **dict.fromkeys(own, 1)})["value"] == sub["value"]
    for typo, meant in (("vaule", "value"), ("Value", "value"), ("objectiv", "objective"), ("plna", "plan"),
                        ("instnace", "instance")):
        with pytest.raises(OptionError, match=f'"{typo}": unknown field; did you mean {meant}\\?'):
            voilib.score({**sub, typo: 1})


def test_score_needs_an_objective_but_no_value():
    sub = _submission("paper-n4-t30-000", "mean-min-voi")
    unstated = {k: v for k, v in sub.items() if k != "value"}
    assert voilib.score(unstated)["value"] == sub["value"]  # the simulator's value either way
    with pytest.raises(OptionError, match=r"^result: objective: is required \(one of min-voi, "):
        voilib.score({k: v for k, v in sub.items() if k != "objective"})


def test_bench_commands(capsys, tmp_path):
    code, out, _ = run_cli(capsys, "bench", "list")
    assert code == 0 and "paper-n4-t30-000" in out and "factory-n12-t100-000" in out
    code, _, _ = run_cli(capsys, "bench", "export", "--out", str(tmp_path / "lib"))
    assert code == 0
    exported = json.loads((tmp_path / "lib" / "certificates.json").read_text())
    for entry in exported["instances"].values():  # the shipped certificates, each with its provenance
        for cert in entry["certificates"].values():
            assert cert.pop("provenance")["proved_by"]["method"] == cert["bound_method"]
    shipped = {**CERTS, "instances": {n: {**e, "certificates": {o: {k: v for k, v in c.items() if k != "provenance"}
                                                               for o, c in e["certificates"].items()}}
                                      for n, e in CERTS["instances"].items()}}  # merged ones ship theirs
    assert exported == shipped and len(list((tmp_path / "lib").glob("*.json"))) == len(LIB) + 1
    honest = tmp_path / "honest.json"
    honest.write_text(json.dumps(_submission("walls-n4-t30-000", "max-aoi", "shortest-path")))
    code, out, _ = run_cli(capsys, "bench", "score", str(honest))
    assert code == 0 and "walls-n4-t30-000" in out and "%" in out
    forged = tmp_path / "forged.json"
    d = _submission("walls-n4-t30-000", "max-aoi")
    d["value"] = d["value"] - 1
    forged.write_text(json.dumps(d))
    code, out, err = run_cli(capsys, "bench", "score", str(forged), str(honest))  # the good file is still scored
    assert code == 2 and "is not what its plan gives" in one_line_error(err) and "walls-n4-t30-000" in out
    code, out, err = run_cli(capsys, "bench", "score", str(forged), str(honest), str(forged))  # a line per bad file
    assert code == 2 and err.count("is not what its plan gives") == 2 and len(err.strip().splitlines()) == 2
    unknown = tmp_path / "unknown.json"
    unknown.write_text(json.dumps({**d, "instance": "nope"}))
    code, _, err = run_cli(capsys, "bench", "score", str(unknown))
    assert code == 2 and f"is no VoI-Lib {voilib.VERSION} instance" in one_line_error(err)


def test_certify_rebuilds_the_shipped_certificates_and_resumes(tmp_path, capsys):
    names = ["paper-n3-t10-000"]
    code, _, _ = run_cli(capsys, "bench", "certify", "--work", str(tmp_path / "work"), "--into", str(tmp_path),
                     "--only", ",".join(names), "--quiet")
    assert code == 0
    made = json.loads((tmp_path / "certificates.json").read_text())
    for name in names:
        for objective in OBJECTIVES:
            got, shipped = made["instances"][name]["certificates"][objective], \
                CERTS["instances"][name]["certificates"][objective]
            assert (got["status"], got["value"]) == (shipped["status"], shipped["value"])
    stamps = {p: p.stat().st_mtime_ns for p in (tmp_path / "work").iterdir()}
    assert len(stamps) == len(names) * len(OBJECTIVES) * 2 + 2  # the results, instances.sha256 and run.json
    run_cli(capsys, "bench", "certify", "--work", str(tmp_path / "work"), "--into", str(tmp_path), "--only",
        ",".join(names), "--quiet")
    assert {p: p.stat().st_mtime_ns for p in (tmp_path / "work").iterdir()} == stamps  # resumed: nothing re-run
    for other in (["--time-limit", "120"], ["--threads", "2"]):  # another run's settings: not silently reused
        code, out, err = run_cli(capsys, "bench", "certify", "--work", str(tmp_path / "work"), "--into", str(tmp_path),
                             "--only", ",".join(names), "--quiet", *other)
        line = one_line_error(err)
        assert code == 2 and "--work: " in line and "holds a run with other settings" in line, line
        assert other[0][2:].replace("-", "_") + " differs" in line, line
    assert {p: p.stat().st_mtime_ns for p in (tmp_path / "work").iterdir()} == stamps


@pytest.mark.parametrize("doc, message", [
    ([1, 2], "must be a result object with instance, objective and plan"),
    ({"instance": ["x"], "objective": "max-aoi", "plan": {}}, f'instance: ["x"] is no VoI-Lib {voilib.VERSION} instance'),
    ({"instance_sha256": 7, "objective": "max-aoi", "plan": {}}, f"instance_sha256: 7 is no VoI-Lib {voilib.VERSION} instance"),
    ({"instance": "case-study", "objective": "best", "plan": {}}, "objective: must be one of"),
    ({"instance": "case-study", "objective": "max-aoi"}, "plan: is required"),
    ({"instance": "case-study", "objective": "max-aoi", "plan": {"positions": [], "schedule": []}},
     "positions: must have horizon = 10 entries, got 0"),
    ({"instance": "case-study", "objective": "max-aoi", "plan": case_study_plan().to_dict(),
      "value": "12"}, 'value: must be a finite number (or null, or absent), got "12"'),
    ({"instance": "case-study", "objective": "max-aoi", "plan": case_study_plan().to_dict(),
      "value": True}, "value: must be a finite number (or null, or absent), got true"),
    ({"objective": "max-aoi", "plan": case_study_plan().to_dict()}, "instance: is required"),
    (case_study().to_dict(), "an instance, not a result"),
    ({"version": 1, "instances": {}}, "a certificates file, not a result"),
    ({"instance": "case-study", "objective": ["max-aoi"], "plan": {}}, 'objective: must be one of'),
    ({"instance": "case-study", "objective": "max-aoi", "plan": case_study_plan().to_dict(), "vaule": 3},
     '"vaule": unknown field; did you mean value?'),
    ({"instance": "case-study", "objectiv": "max-aoi", "plan": case_study_plan().to_dict()},
     '"objectiv": unknown field; did you mean objective?'),
    ({"instance": "case-study", "objective": {"a": 1}, "plan": {}}, 'got {"a": 1}'),
    ({"instance": "case-study", "objective": "max-aoi", "plan": {"schedule": []}}, "plan.positions: is required"),
    ({"instance": "case-study", "objective": "max-aoi", "plan": {**case_study_plan().to_dict(), "speed": 1}},
     "plan.speed: unknown field"),
    ({"instance": "paper-n4-t30-000", "objective": "max-aoi", "plan": case_study_plan().to_dict(),
      "instance_sha256": voilib.instance_hash(case_study())},
     '"paper-n4-t30-000" is not the instance its instance_sha256 names (case-study)'),
])
def test_hostile_submissions_are_one_line_errors_naming_the_file(capsys, tmp_path, doc, message):
    path = tmp_path / "sub.json"
    path.write_text(json.dumps(doc))
    code, out, err = run_cli(capsys, "bench", "score", str(path))
    line = one_line_error(err)
    assert code == 2 and out == "" and line.startswith(f"voiopt: error: {path}: ") and message in line, line


def test_certify_only_updates_those_entries_and_keeps_the_others(tmp_path, capsys):
    (tmp_path / "certificates.json").write_text(json.dumps(CERTS))
    code, _, _ = run_cli(capsys, "bench", "certify", "--work", str(tmp_path / "work"), "--into", str(tmp_path),
                     "--only", "paper-n3-t10-000", "--quiet", "--time-limit", "10", "--threads", "2")
    assert code == 0
    for objective in OBJECTIVES:  # each run was given the threads
        dp_run = json.loads((tmp_path / "work" / f"paper-n3-t10-000__{objective}__dp.json").read_text())
        assert dp_run["solver"]["options"]["threads"] == 2
    made = json.loads((tmp_path / "certificates.json").read_text())
    assert list(made["instances"]) == list(CERTS["instances"])  # every instance, in the library's order
    for name, entry in CERTS["instances"].items():
        if name != "paper-n3-t10-000":
            assert made["instances"][name] == entry
    fresh = made["instances"]["paper-n3-t10-000"]["certificates"]["max-aoi"]
    assert fresh["checks"] != CERTS["instances"]["paper-n3-t10-000"]["certificates"]["max-aoi"]["checks"]  # re-run


def test_an_open_certificate_is_shown_with_digits_enough_to_tell_its_ends_apart():
    assert voilib.show_certificate({"status": "optimal", "value": 38459.7123, "bound": 38459.7123}) == "38459.7"
    assert voilib.show_certificate({"status": "feasible", "value": 38459.71, "bound": 38459.74}) == "[38459.71, 38459.74]"
    assert voilib.show_certificate({"status": "feasible", "value": 31.05, "bound": 51.5}) == "[31.05, 51.5]"


def test_a_certificate_without_a_plan_says_why_each_run_had_none():
    """With a memory limit below every method's tables, certify said only 'no method returned
    a plan'; the cause was in the --work files alone (a probe, 2026-12-03)."""
    inst = case_study()
    runs = [Result(inst.name, m, "min-voi", "error", None, None, None, 0.0, None, None,
                   {"error": f"MemoryLimitError: --memory-limit: {m}'s tables need more\nsecond line"})
            for m in ("dp", "milp")]
    with pytest.raises(VoioptError) as e:
        voilib.certificate_of(inst, "min-voi", runs)
    assert str(e.value) == ("certify: case-study min-voi: no method returned a plan (dp: error (MemoryLimitError: "
                            "--memory-limit: dp's tables need more); milp: error (MemoryLimitError: --memory-limit: "
                            "milp's tables need more))")


def test_a_score_says_when_the_value_is_another_objectives_or_the_plan_another_instances():
    """A max-aoi result relabelled mean-min-voi was asked whether it was solved on another
    instance; a plan of another instance got the bare start rule (a probe, 2026-12-03)."""
    r = voiopt.solve(LIB["paper-n3-t10-000"], "dp", "max-aoi").to_dict()
    with pytest.raises(OptionError, match=r"it is the plan's max-aoi: is objective right\?$"):
        voilib.score({**r, "objective": "mean-min-voi"})
    plan = case_study_plan().to_dict()
    with pytest.raises(voiopt.PlanError, match=r"^positions\[0\]: must equal start .*\(checked against VoI-Lib's "
                                               r"paper-n3-t10-000\)$"):
        voilib.score({"instance": "paper-n3-t10-000", "objective": "mean-min-voi", "plan": plan})


def test_an_instance_sha256_is_read_in_either_case_and_shown_whole():
    plan = voiopt.solve(LIB["paper-n3-t10-000"], "greedy").to_dict()
    digest = voilib.instance_hash(LIB["paper-n3-t10-000"])
    row = voilib.score({"instance_sha256": digest.upper(), "objective": "mean-min-voi", "plan": plan["plan"]})
    assert row["instance"] == "paper-n3-t10-000"
    wrong = "f" * 64
    with pytest.raises(OptionError, match=rf'^instance_sha256: "{wrong}" is no VoI-Lib'):
        voilib.score({"instance_sha256": wrong, "objective": "mean-min-voi", "plan": plan["plan"]})
