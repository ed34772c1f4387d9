"""VoI-Lib's certificates are never weakened: certify writes where it is told, and the one
step that updates the shipped file refuses a weaker or disagreeing certificate (issue 47)."""

from __future__ import annotations

import copy
import json

import pytest
from conftest import run_cli
from test_cli import one_line_error

from voiopt.errors import OptionError
from voiopt.voilib import library as voilib
from voiopt.voilib import merge as voilib_merge
from voiopt.voilib.certificates import provenance, verdict

SHIPPED = voilib.DATA / "certificates.json"


def test_certify_with_default_options_leaves_the_shipped_certificates_byte_identical(tmp_path, capsys):
    before = SHIPPED.read_bytes()
    try:
        code, out, _ = run_cli(capsys, "bench", "certify", "--work", str(tmp_path / "work"), "--only",
                           "paper-n3-t10-000", "--time-limit", "2", "--quiet")
        assert SHIPPED.read_bytes() == before
    finally:  # the code before this issue rewrote it: put it back whatever happened
        if SHIPPED.read_bytes() != before:
            with open(str(SHIPPED), "wb") as f:
                f.write(before)
    assert code == 0 and str(tmp_path / "work" / "certificates.json") in out
    made = json.loads((tmp_path / "work" / "certificates.json").read_text())
    assert list(made["instances"]) == ["paper-n3-t10-000"]
    cert = made["instances"]["paper-n3-t10-000"]["certificates"]["max-aoi"]
    assert cert["provenance"]["proved_by"]["method"] == cert["bound_method"]
    assert cert["provenance"]["proved_by"]["date"] is not None  # a new certificate records its day


def _shipped_copy(tmp_path):
    target = tmp_path / "shipped.json"
    target.write_bytes(SHIPPED.read_bytes())
    return target


def _source(tmp_path, name, objective, **change):
    cert = copy.deepcopy(voilib.certificates()["instances"][name])
    cert["certificates"] = {objective: {**cert["certificates"][objective], **change}}
    path = tmp_path / "new" / "certificates.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps({"version": voilib.VERSION, "instances": {name: cert}}))
    return path.parent


@pytest.mark.parametrize("change, why", [
    (dict(status="bounded", bound=1.0e-3, value=2.63e-9), "is weaker"),  # the probe's open interval
    (dict(value=1.5), "disagrees"),  # another optimum
])
def test_merge_refuses_a_weaker_or_disagreeing_certificate_and_writes_nothing(tmp_path, capsys, change, why):
    target = _shipped_copy(tmp_path)
    before = target.read_bytes()
    source = _source(tmp_path, "paper-n4-t20-000", "min-voi", **change)
    code, out, err = run_cli(capsys, "bench", "merge-certificates", str(source), "--into", str(target))
    line = one_line_error(err)
    assert code == 2 and why in line and "paper-n4-t20-000 min-voi" in line and "nothing merged" in line, line
    assert target.read_bytes() == before


def test_merge_takes_a_tighter_interval_and_keeps_the_others(tmp_path):
    target = tmp_path / "shipped.json"
    certs = copy.deepcopy(voilib.certificates())
    name = "paper-n3-t10-000"
    shipped = certs["instances"][name]["certificates"]["max-aoi"]
    wide = {**shipped, "status": "bounded", "bound": shipped["value"] - 3, "gap": 3 / (shipped["value"] - 3)}
    certs["instances"][name]["certificates"]["max-aoi"] = wide
    target.write_text(json.dumps(certs))
    path, changed = voilib_merge.merge(_source(tmp_path, name, "max-aoi"), target)
    assert changed == [f"{name} max-aoi"]
    merged = json.loads(path.read_text())
    assert merged["instances"][name]["certificates"]["max-aoi"]["status"] == "optimal"
    assert merged["instances"][name]["certificates"]["min-voi"] == certs["instances"][name]["certificates"]["min-voi"]
    assert list(merged["instances"]) == list(certs["instances"])
    with pytest.raises(OptionError, match="is weaker"):  # and back is refused
        voilib_merge.merge(_write(tmp_path / "w.json", name, wide), path)


def _write(path, name, cert):
    entry = {"sha256": voilib.instance_hash(voilib.instances()[name]), "certificates": {"max-aoi": cert}}
    path.write_text(json.dumps({"version": voilib.VERSION, "instances": {name: entry}}))
    return path


def test_merge_refuses_an_edited_instance_or_another_version(tmp_path):
    target = _shipped_copy(tmp_path)
    src = _source(tmp_path, "case-study", "max-aoi") / "certificates.json"
    d = json.loads(src.read_text())
    d["instances"]["case-study"]["sha256"] = "0" * 64
    src.write_text(json.dumps(d))
    with pytest.raises(OptionError, match="case-study: is no VoI-Lib"):
        voilib_merge.merge(src, target)
    d["version"] = "0.9"
    src.write_text(json.dumps(d))
    with pytest.raises(OptionError, match="version: '0.9'"):
        voilib_merge.merge(src, target)


def test_verdict_reads_intervals_by_the_objectives_sense():
    opt = {"status": "optimal", "value": 10.0, "bound": 10.0}
    assert verdict("max-aoi", opt, {"status": "bounded", "value": 12.0, "bound": 9.0}).startswith("is weaker")
    assert verdict("max-aoi", opt, {"status": "bounded", "value": 12.0, "bound": 11.0}).startswith("disagrees")
    assert verdict("min-voi", {"status": "bounded", "value": 1.0, "bound": None},
                   {"status": "bounded", "value": 2.0, "bound": 3.0}) is None
    assert verdict("min-voi", {"status": "bounded", "value": 1.0, "bound": 3.0},
                   {"status": "bounded", "value": 1.0, "bound": 4.0}).startswith("is weaker")


def test_every_shipped_certificate_has_provenance_from_what_is_known():
    for name, entry in voilib.certificates()["instances"].items():
        for objective, cert in entry["certificates"].items():
            p = provenance(cert)
            assert p["proved_by"]["method"] == cert["bound_method"] and p["found_by"] == cert["method"]
            assert p["proved_by"]["voiopt_version"] == cert["voiopt_version"]
            for m in p["confirmed_by"]:
                assert m != cert["bound_method"] and cert["checks"][m]["status"] == "optimal", (name, objective)


# ------------------------------------------------------------ VoI-Lib as benchmark users expect


def test_export_writes_a_readme_and_a_solution_per_instance_and_objective_that_score_to_a_zero_gap(tmp_path, capsys):
    code, _, _ = run_cli(capsys, "bench", "export", "--out", str(tmp_path / "lib"))
    assert code == 0
    readme = (tmp_path / "lib" / "README.md").read_text()
    certs = voilib.certificates()["instances"]
    for row in voilib.table_rows():
        assert f"| {row['name']} | {row['N']} | {row['T']} |" in readme and row["mean-min-voi"] in readme
    assert "bench score" in readme and "exit status" in readme and "sha256" in readme
    solutions = sorted((tmp_path / "lib" / "solutions").iterdir())
    assert len(solutions) == sum(len(e["certificates"]) for e in certs.values())
    exported = json.loads((tmp_path / "lib" / "certificates.json").read_text())
    assert all("provenance" in c for e in exported["instances"].values() for c in e["certificates"].values())
    picked = [p for p in solutions if p.name.startswith(("walls-n4-t30-002__", "case-study__"))]
    code, out, _ = run_cli(capsys, "bench", "score", "--json", *map(str, picked))
    rows = json.loads(out)
    assert code == 0 and len(rows) == 8
    for r in rows:
        assert r["gap_to_bound"] == 0.0 and r["gap_to_best"] == 0.0, r
        assert r["value"] == certs[r["instance"]]["certificates"][r["objective"]]["value"]


def test_a_bare_plan_is_scored_with_instance_and_objective_as_json_or_csv(tmp_path, capsys):
    cert = voilib.certificates()["instances"]["paper-n4-t20-001"]["certificates"]["mean-max-aoi"]
    plan = tmp_path / "plan.json"
    plan.write_text(json.dumps(cert["plan"]))
    code, out, _ = run_cli(capsys, "bench", "score", str(plan), "--instance", "paper-n4-t20-001", "--objective",
                       "mean-max-aoi", "--json")
    (row,) = json.loads(out)
    assert code == 0 and row["value"] == cert["value"] and row["gap_to_bound"] == 0.0 and row["status"] is None
    idle = {"positions": [cert["plan"]["positions"][0]] * len(cert["plan"]["positions"]),
            "schedule": [None] * len(cert["plan"]["schedule"])}
    plan.write_text(json.dumps(idle))
    code, out, _ = run_cli(capsys, "bench", "score", str(plan), "--instance", "paper-n4-t20-001", "--objective",
                       "mean-max-aoi", "--csv")
    header, line = out.strip().splitlines()
    row = dict(zip(header.split(","), line.split(","), strict=True))
    assert code == 0 and float(row["gap_to_bound"]) > 0 and float(row["value"]) > cert["value"]
    code, _, err = run_cli(capsys, "bench", "score", str(plan), "--instance", "paper-n4-t20-001")
    assert code == 2 and "give both" in one_line_error(err)


def test_bench_score_shows_a_results_own_status(tmp_path, capsys):
    cert = voilib.certificates()["instances"]["case-study"]["certificates"]["max-aoi"]
    path = tmp_path / "r.json"
    path.write_text(json.dumps({"instance": "case-study", "objective": "max-aoi", "plan": cert["plan"],
                                "status": "interrupted", "method": "milp"}))
    code, out, _ = run_cli(capsys, "bench", "score", str(path))
    assert code == 0 and "interrupted" in out


@pytest.mark.parametrize("doc, code", [
    ("good", 0), ("illegal", 3), ("forged", 4), ("not json", 5), (None, 5), ("unknown", 2)])
def test_the_checker_has_an_exit_status_for_each_verdict(tmp_path, capsys, doc, code):
    cert = voilib.certificates()["instances"]["case-study"]["certificates"]["min-voi"]
    good = {"instance": "case-study", "objective": "min-voi", "plan": cert["plan"], "value": cert["value"]}
    docs = {"good": good, "forged": {**good, "value": cert["value"] * 1.01},
            "illegal": {**good, "plan": {**cert["plan"], "schedule": [0] * len(cert["plan"]["schedule"])}},
            "unknown": {**good, "instance": "no-such"}}
    path = tmp_path / "sub.json"
    if doc is not None:
        path.write_text(json.dumps(docs[doc]) if doc in docs else '{"instance": "case-')
    got, out, err = run_cli(capsys, "bench", "check", str(path))
    assert got == code, (out, err)
    if code == 0:
        assert out.startswith("valid: case-study min-voi") and err == ""
    else:
        assert one_line_error(err).startswith(f"voiopt: error: {path}")
