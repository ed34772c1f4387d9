"""VoI-Lib's certificates are never weakened: certify writes where it is told, and the one
step that updates the shipped file refuses a weaker or disagreeing certificate (issue 47)."""

from __future__ import annotations

import copy
import json

import pytest
from test_cli import one_line_error, run

from voiopt.errors import OptionError
from voiopt.experiments import voilib, voilib_merge
from voiopt.experiments.voilib_certificates import provenance, verdict

SHIPPED = voilib.DATA / "certificates.json"


def test_certify_with_default_options_leaves_the_shipped_certificates_byte_identical(tmp_path, capsys):
    before = SHIPPED.read_bytes()
    try:
        code, out, _ = run(capsys, "bench", "certify", "--work", str(tmp_path / "work"), "--only",
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
    code, out, err = run(capsys, "bench", "merge-certificates", str(source), "--into", str(target))
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
