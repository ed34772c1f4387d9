"""VoI-Lib's lossy set (MODEL.md section 11): frozen instances that are their regeneration,
labelled certificates whose exact values an independent oracle reproduces, scoring of plans
and policies that never trusts a stated value, and merges that never weaken a label."""

from __future__ import annotations

import copy
import json

import pytest
from conftest import run_cli
from oracles.expectimax import oracle
from test_cli import one_line_error

import voiopt
from voiopt.core.links import is_lossy, without_links
from voiopt.core.policy import Policy
from voiopt.core.result import BoundKind, Evaluation
from voiopt.errors import OptionError
from voiopt.objectives import BY_NAME, OBJECTIVES, better
from voiopt.voilib import library as voilib
from voiopt.voilib import lossy
from voiopt.voilib import merge as voilib_merge
from voiopt.voilib.certificates import verdict

LIB = voilib.instances()
CERTS = voilib.certificates()["instances"]
LOSSY = {n: i for n, i in LIB.items() if is_lossy(i)}
SMALL = "lossy-case-study-b50"


def test_the_lossy_set_is_its_regeneration_and_each_twin_is_a_lossless_instance_with_links():
    assert len(LOSSY) == len(lossy.LOSSY_LADDER) >= 7
    lossless = {n: i for n, i in LIB.items() if n not in LOSSY}
    for inst in lossy.lossy_ladder(lossless):
        assert voilib.instance_hash(inst) == voilib.instance_hash(LOSSY[inst.name]), inst.name
    for name, source, links in lossy.LOSSY_LADDER:
        if isinstance(source, str):
            twin = without_links(LOSSY[name]).to_dict()
            assert twin | {"name": source} == LIB[source].to_dict()
            assert LOSSY[name].to_dict()["links"] == links
    models = {i.links.model for i in LOSSY.values()}
    assert models == {"bernoulli", "rayleigh"}


@pytest.mark.parametrize("name", sorted(LOSSY))
def test_every_lossy_certificate_is_labelled_and_its_plan_valued_exactly(name):
    inst = LOSSY[name]
    assert CERTS[name]["sha256"] == voilib.instance_hash(inst)
    assert set(CERTS[name]["certificates"]) == set(OBJECTIVES)
    for objective, cert in CERTS[name]["certificates"].items():
        expected = voiopt.expected_metrics(inst, cert["plan"])[objective]
        assert expected == cert["plan_value"] and cert["plan_evaluation"] == Evaluation.EXACT
        assert cert["evaluation"] == Evaluation.EXACT and BoundKind(cert["bound_kind"]).proven
        assert not better(objective, cert["plan_value"], cert["lossless_bound"])  # no plan beats the lossless bound
        if cert["status"] == "optimal":  # a policy's exact value, met by an exact bound
            assert BY_NAME[objective].per_slot and cert["bound_kind"] == BoundKind.EXACT
            assert cert["value"] == cert["bound"] and cert["value_of"] == "policy"
            assert not better(objective, cert["plan_value"], cert["value"])  # adaptivity is worth >= 0
            assert not better(objective, cert["value"], cert["lossless_bound"])
        else:  # the best plan's exact value and the proven lossless bound; a plan is not a policy
            assert cert["status"] == "bounded" and cert["bound_kind"] == BoundKind.LOSSLESS
            assert (cert["value"], cert["bound"]) == (cert["plan_value"], cert["lossless_bound"])
        ir = cert["information_relaxation"]
        if ir is not None:  # statistical: beside the bound, never the bound
            assert ir["bound_kind"] == BoundKind.INFORMATION_RELAXATION and ir["samples"] >= 2 and ir["confidence"]
        source = next((s for n, s, _ in lossy.LOSSY_LADDER if n == name), None)
        if isinstance(source, str):  # the lossless twin's certified optimum is the lossless bound
            twin = CERTS[source]["certificates"][objective]["bound"]
            assert cert["lossless_bound"] == pytest.approx(twin, rel=1e-12)


def test_the_small_entries_are_optimal_and_the_paper_scale_entry_is_exact_only_for_mean_max_aoi():
    """At the paper's scale policy-dp finishes for mean-max-aoi (no distances in its states), not
    for mean-min-voi; the bottleneck objectives have no exact policy (MODEL.md 11)."""
    for name in ("lossy-case-study-b90", "lossy-paper-n4-t12-b70-000", "lossy-paper-n3-t14-r27-000"):
        for objective in ("mean-min-voi", "mean-max-aoi"):
            assert CERTS[name]["certificates"][objective]["status"] == "optimal", (name, objective)
    big = CERTS["lossy-paper-n4-t30-b70"]["certificates"]
    assert {k: c["status"] for k, c in big.items()} == {"min-voi": "bounded", "mean-min-voi": "bounded",
                                                       "max-aoi": "bounded", "mean-max-aoi": "optimal"}
    exact = big["mean-max-aoi"]
    assert exact["value"] == exact["bound"] and exact["bound_kind"] == "exact"
    assert exact["lossless_bound"] <= exact["value"] <= exact["plan_value"]  # AoI: lower is better


@pytest.mark.parametrize("name", ["lossy-case-study-b50", "lossy-case-study-b90"])
def test_exact_certificates_equal_an_independent_expectimax(name):
    """The oracle (tests/oracles/expectimax.py, written from MODEL.md alone) enumerates every
    history: its optimal policy's value is the certificate's."""
    for objective in ("mean-min-voi", "mean-max-aoi"):
        cert = CERTS[name]["certificates"][objective]
        assert cert["value"] == pytest.approx(oracle(LOSSY[name].to_dict(), objective), rel=1e-9)


def _score(*paths):
    rows, errors = voilib.score_files([str(p) for p in paths])
    assert errors == []
    return rows


def _write(tmp_path, doc, name="r.json"):
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


def test_a_plan_is_scored_at_its_exact_expectation_with_a_gap_to_the_exact_bound(tmp_path, capsys):
    inst = LOSSY[SMALL]
    result = voiopt.solve(inst, "dp", "mean-min-voi")
    path = tmp_path / "dp.json"
    result.save(path)
    (row,) = _score(path)  # the rows bench score prints (its --json and --csv columns are the CLI's)
    cert = CERTS[SMALL]["certificates"]["mean-min-voi"]
    assert row["value"] == voiopt.expected_metrics(inst, result.plan)["mean-min-voi"] == result.value
    assert row["evaluation"] == "exact" and row["bound_kind"] == "exact" and row["samples"] is None
    assert row["certified_status"] == "optimal" and row["certified_value"] == cert["value"]
    assert row["gap_to_bound"] >= 0 and row["gap_to_best"] >= 0
    assert row["gap_to_bound"] > 0  # dp's open-loop plan is worth less than the optimal policy here
    lossless_value = voiopt.evaluate(without_links(inst), result.plan)["mean-min-voi"]
    for forged in (result.value * 1.01, lossless_value):  # a stated value is re-computed, never trusted
        code, _, err = run_cli(capsys, "bench", "check", str(_write(tmp_path, {**result.to_dict(), "value": forged})))
        assert code == 4 and "is not what its plan gives" in one_line_error(err) and "exact" in err


def test_a_policy_is_revalued_exactly_and_a_forged_value_refused(tmp_path, capsys):
    """policy-dp's saved policy scores to the certified optimum (gap 0), whatever its result
    file says; its table must be of the library's instance."""
    path = tmp_path / "pdp.json"
    code, _, err = run_cli(capsys, "solve", LOSSY_FILE(SMALL), "--method", "policy-dp", "--objective",
                           "mean-max-aoi", "-o", str(path))
    assert code == 0, err
    doc = json.loads(path.read_text())
    assert doc["solver"]["policy_file"] == "pdp.policy.json" and doc["plan"] is None
    (row,) = _score(path)
    cert = CERTS[SMALL]["certificates"]["mean-max-aoi"]
    assert row["scored"] == "policy" and row["evaluation"] == "exact"
    assert row["value"] == pytest.approx(cert["value"], rel=1e-12) and row["gap_to_bound"] <= 1e-12
    code, _, err = run_cli(capsys, "bench", "check", str(_write(tmp_path, {**doc, "value": doc["value"] + 0.5},
                                                                  "pdp-forged.json")))
    assert code == 4 and "is not what its policy gives" in one_line_error(err)
    other = Policy.load(tmp_path / "pdp.policy.json")
    other.instance = LOSSY["lossy-case-study-b70"]  # the same table, saved as another instance's
    other.save(tmp_path / "other.policy.json")
    bad = _write(tmp_path, {**doc, "solver": {**doc["solver"], "policy_file": "other.policy.json"}}, "bad.json")
    code, _, err = run_cli(capsys, "bench", "score", str(bad))
    assert code == 2 and "solver.policy_file" in one_line_error(err) and "another instance" in err


def LOSSY_FILE(name):  # noqa: N802 (a path, like a constant)
    return str(voilib.DATA / "instances" / f"{name}.json")


def test_a_policy_too_big_to_enumerate_is_scored_by_monte_carlo_on_the_librarys_scenarios(tmp_path, capsys,
                                                                                          monkeypatch):
    from voiopt.voilib import lossy_score

    path = tmp_path / "p.json"
    run_cli(capsys, "solve", LOSSY_FILE(SMALL), "--method", "policy-dp", "--objective", "mean-max-aoi", "-o", str(path))
    monkeypatch.setattr(lossy_score, "MAX_STATES", 10)
    monkeypatch.setattr(lossy_score, "SCORE_SAMPLES", 300)
    rows = [_score(path)[0] for _ in range(2)]
    assert rows[0] == rows[1]  # the library's fixed scenarios: every scorer meets the same outcomes
    row = rows[0]
    lo, hi = row["value_ci"]
    assert row["evaluation"] == "monte-carlo" and row["samples"] == 300 and lo <= row["value"] <= hi
    assert lo <= CERTS[SMALL]["certificates"]["mean-max-aoi"]["value"] <= hi


def test_bench_list_shows_links_and_the_bound_kind(capsys):
    code, out, _ = run_cli(capsys, "bench", "list", "--markdown")
    lines = {line.split(" | ")[0].strip("| "): line for line in out.splitlines()}
    assert code == 0 and "| links |" in out
    assert "bernoulli:0.5" in lines[SMALL] and "(exact)" in lines[SMALL] and "(lossless)" in lines[SMALL]
    assert "rayleigh:27" in lines["lossy-paper-n3-t14-r27-000"]
    big = lines["lossy-paper-n4-t30-b70"]
    assert big.count("(exact)") == 1 and big.count("(lossless)") == 3 and "(" not in lines["case-study"]


def _lossy_source(tmp_path, objective, **change):
    entry = copy.deepcopy(voilib.certificates()["instances"][SMALL])
    entry["certificates"] = {objective: {**entry["certificates"][objective], **change}}
    path = tmp_path / "new" / "certificates.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(json.dumps({"version": voilib.VERSION, "instances": {SMALL: entry}}))
    return path


@pytest.mark.parametrize("change, why", [
    (dict(evaluation="monte-carlo", samples=100, value_ci=[1.0, 2.0]), "optimal needs both exact"),
    (dict(status="bounded", evaluation="monte-carlo", value_ci=[1.0, 2.0]), "monte-carlo value would replace an exact"),
    (dict(status="bounded", bound_kind="information-relaxation"), "statistical"),
    (dict(status="bounded", bound_kind="lossless"), "is weaker"),
    (dict(value=9.0, bound=9.0), "disagrees"),
    (dict(bound_kind=None), "a certificate of a lossy instance says what its numbers are"),
])
def test_merge_never_weakens_an_exact_lossy_certificate(tmp_path, change, why):
    target = tmp_path / "shipped.json"
    target.write_bytes((voilib.DATA / "certificates.json").read_bytes())
    before = target.read_bytes()
    with pytest.raises(OptionError, match=why):
        voilib_merge.merge(_lossy_source(tmp_path, "mean-max-aoi", **change), target)
    assert target.read_bytes() == before
    path, changed = voilib_merge.merge(_lossy_source(tmp_path, "mean-max-aoi"), target)  # the same: nothing to do
    assert changed == [] and target.read_bytes() == before


def test_verdict_takes_a_proven_lossy_interval_that_tightens():
    old = {"status": "bounded", "value": 5.0, "bound": 10.0, "bound_kind": "lossless", "evaluation": "exact"}
    assert verdict("mean-min-voi", old, {**old, "value": 6.0}) is None
    assert verdict("mean-min-voi", old, {**old, "status": "optimal", "value": 7.0, "bound": 7.0,
                                         "bound_kind": "exact"}) is None
    assert "statistical" in verdict("mean-min-voi", old, {**old, "bound": 8.0, "bound_kind": "information-relaxation"})


def test_export_covers_the_lossy_set_and_its_solutions_score(tmp_path, capsys):
    code, _, _ = run_cli(capsys, "bench", "export", "--out", str(tmp_path / "lib"))
    assert code == 0
    readme = (tmp_path / "lib" / "README.md").read_text()
    assert "lossy" in readme and "bernoulli:0.7" in readme and "information-relaxation" in readme
    for cert in CERTS[SMALL]["certificates"].values():  # the optimal policies beside certificates.json
        assert cert["policy_file"] is None or lossy.file_hash(tmp_path / "lib" / cert["policy_file"]) == \
            cert["policy_sha256"]
    picked = sorted((tmp_path / "lib" / "solutions").glob(f"{SMALL}__*.json"))
    assert len(picked) == len(OBJECTIVES)
    for row in _score(*picked):
        cert = CERTS[SMALL]["certificates"][row["objective"]]
        assert row["value"] == cert["plan_value"] and row["gap_to_bound"] >= 0
        assert row["gap_to_best"] == 0.0 if cert["value_of"] == "plan" else row["gap_to_best"] > 0


def test_the_stored_optimal_policies_are_worth_their_certificates_and_score_to_a_zero_gap():
    """Each exact certificate ships its optimal policy (its file is small): of the instance, of
    the sha256 the certificate names, and worth the certified value by its own enumeration."""
    from voiopt.core.policy_value import exact_value

    stored = 0
    for name in LOSSY:
        for objective, cert in CERTS[name]["certificates"].items():
            if cert["status"] != "optimal" or cert["policy_file"] is None:
                # an optimal policy over POLICY_LIMIT bytes is not stored: the value alone
                assert cert["policy_file"] is None and cert.get("policy_sha256") is None
                continue
            path = voilib.DATA / cert["policy_file"]
            assert lossy.file_hash(path) == cert["policy_sha256"] and path.stat().st_size < lossy.POLICY_LIMIT
            policy = Policy.load(path)
            assert voilib.instance_hash(policy.instance) == voilib.instance_hash(LOSSY[name])
            assert exact_value(policy, objective) == pytest.approx(cert["value"], rel=1e-12), (name, objective)
            stored += 1
    assert stored >= 12
    cert = CERTS[SMALL]["certificates"]["mean-min-voi"]
    row = voilib.score({"instance": SMALL, "objective": "mean-min-voi",
                        "solver": {"policy_file": str(voilib.DATA / cert["policy_file"])}})
    assert row["scored"] == "policy" and row["gap_to_bound"] <= 1e-12 and row["evaluation"] == "exact"


def test_merge_refuses_a_stored_policy_that_is_not_worth_its_certificate(tmp_path):
    target = tmp_path / "shipped.json"
    target.write_bytes((voilib.DATA / "certificates.json").read_bytes())
    other = CERTS["lossy-case-study-b70"]["certificates"]["mean-max-aoi"]  # another instance's policy
    source = _lossy_source(tmp_path, "mean-max-aoi", policy_file=other["policy_file"],
                           policy_sha256=other["policy_sha256"])
    with pytest.raises(OptionError, match="missing"):  # the file is not in the source folder
        voilib_merge.merge(source, target)
    (source.parent / "policies").mkdir()
    (source.parent / other["policy_file"]).write_bytes((voilib.DATA / other["policy_file"]).read_bytes())
    with pytest.raises(OptionError, match="not the certified"):
        voilib_merge.merge(source, target)
    assert target.read_bytes() == (voilib.DATA / "certificates.json").read_bytes()


def test_a_files_monte_carlo_estimate_is_not_refused_but_replaced_by_the_exact_value(tmp_path):
    cert = CERTS[SMALL]["certificates"]["mean-min-voi"]
    doc = {"instance": SMALL, "objective": "mean-min-voi", "evaluation": "monte-carlo", "samples": 50,
           "value_ci": [1.0, 2.0], "value": cert["value"] * 0.97,
           "solver": {"policy_file": str(voilib.DATA / cert["policy_file"])}}
    (row,) = _score(_write(tmp_path, doc))
    assert row["evaluation"] == "exact" and row["value"] == pytest.approx(cert["value"], rel=1e-12)
    with pytest.raises(OptionError, match="is not what its policy gives"):
        voilib.score({**doc, "evaluation": "exact"})


def test_where_policy_dp_stops_the_certificate_is_bounded_with_the_relaxation_only_beside_it(monkeypatch, tmp_path):
    """The path of the paper-scale entry, on the small one: policy-dp stopped, the certificate
    is the best plan's exact value and the lossless bound, and the information relaxation
    (computed here in about a second) is stored beside it, labelled statistical."""
    inst, objective = LOSSY[SMALL], "mean-max-aoi"
    shipped = CERTS[SMALL]["certificates"][objective]
    results, checks = lossy.plans(inst, 60.0, None)
    monkeypatch.setattr(lossy, "policy_optimum", lambda *a: {"status": "time_limit", "value": None, "bound": None,
                                                           "runtime_s": 60.0, "states": None})
    cert = lossy.certificate_of(inst, objective, results, checks, time_limit=40.0, memory_limit=None,
                                stamp={"instance_sha256": shipped["instance_sha256"], "voiopt_version": "test"},
                                folder=tmp_path)
    assert cert["status"] == "bounded" and cert["bound_kind"] == "lossless" and cert["policy_file"] is None
    assert (cert["value"], cert["bound"]) == (shipped["plan_value"], shipped["lossless_bound"])
    ir = cert["information_relaxation"]
    assert ir["bound_kind"] == BoundKind.INFORMATION_RELAXATION and ir["samples"] == lossy.IR_SAMPLES
    assert cert["lossless_bound"] < ir["bound"] < shipped["value"]  # tighter than lossless, below the optimum
    assert "is weaker" in verdict(objective, shipped, cert)  # never replaces the exact certificate


def test_certify_remakes_a_lossy_entry_with_its_policies_resumes_and_merges(tmp_path, capsys):
    """bench certify on the small entry (seconds): the shipped values and policies again, byte
    for byte; a second run re-runs nothing; merging it into a copy of the shipped file is
    accepted and puts the policies beside the copy."""
    work, into = tmp_path / "work", tmp_path / "into"
    args = ["bench", "certify", "--work", str(work), "--into", str(into), "--only", SMALL, "--quiet"]
    assert run_cli(capsys, *args)[0] == 0
    made = json.loads((into / "certificates.json").read_text())["instances"][SMALL]["certificates"]
    for objective, cert in made.items():
        shipped = CERTS[SMALL]["certificates"][objective]
        assert (cert["status"], cert["value"], cert["bound"], cert["bound_kind"], cert["policy_sha256"]) == \
            (shipped["status"], shipped["value"], shipped["bound"], shipped["bound_kind"], shipped["policy_sha256"])
        if cert["policy_file"]:
            assert lossy.file_hash(into / cert["policy_file"]) == shipped["policy_sha256"]
    stamps = {p: p.stat().st_mtime_ns for p in work.rglob("*")}
    assert run_cli(capsys, *args)[0] == 0
    assert {p: p.stat().st_mtime_ns for p in work.rglob("*")} == stamps  # resumed: nothing re-run
    target = tmp_path / "copy" / "certificates.json"
    target.parent.mkdir()
    target.write_bytes((voilib.DATA / "certificates.json").read_bytes())
    _, changed = voilib_merge.merge(into, target)
    assert set(changed) <= {f"{SMALL} {o}" for o in OBJECTIVES}  # accepted (new runtimes, dates)
    assert all((target.parent / c["policy_file"]).is_file() for c in made.values() if c["policy_file"])
