"""The command line: exit codes, one-line errors, no tracebacks."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT, one_line_error, run_cli

import voiopt
from voiopt.cli.main import main
from voiopt.networks.generate import case_study_plan

CASE_STUDY_PLAN = case_study_plan().to_dict()

CASE = str(ROOT / "instances" / "case-study.json")
PLAN = str(ROOT / "instances" / "case-study.plan.json")




def test_validate_ok_and_bad(capsys, tmp_path):
    assert run_cli(capsys, "validate", CASE)[:2] == (0, "ok\n")
    bad = tmp_path / "bad.json"
    d = voiopt.case_study().to_dict()
    d["sensors"][2]["rho"] = 1.0
    bad.write_text(json.dumps(d))
    code, out, err = run_cli(capsys, "validate", str(bad))
    assert code == 2
    assert one_line_error(err) == f"{bad}: sensors[2].rho: must be in (0, 1), got 1.0"


def test_validate_lists_every_error(capsys, tmp_path):
    bad = tmp_path / "bad.json"
    d = voiopt.case_study().to_dict()
    d["sensors"][0]["rho"] = 0
    d["horizon"] = -3
    bad.write_text(json.dumps(d))
    code, _, err = run_cli(capsys, "validate", str(bad))
    assert code == 2 and len(err.strip().splitlines()) == 2


def test_evaluate_table_and_json(capsys, tmp_path):
    code, out, _ = run_cli(capsys, "evaluate", CASE, PLAN)
    assert code == 0 and "mean-min-voi" in out and "7.9" in out
    code, out, _ = run_cli(capsys, "evaluate", CASE, PLAN, "--json")
    metrics = json.loads(out)["metrics"]
    assert metrics == voiopt.evaluate(voiopt.case_study(), CASE_STUDY_PLAN)
    assert set(metrics) == {"min-voi", "mean-min-voi", "max-aoi", "mean-max-aoi"}
    # a whole result JSON works as PLAN too
    result = tmp_path / "result.json"
    result.write_text(json.dumps({"instance": "case-study", "plan": CASE_STUDY_PLAN}))
    code, out, _ = run_cli(capsys, "evaluate", CASE, str(result), "--json")
    assert json.loads(out)["metrics"] == metrics


@pytest.mark.parametrize(
    "plan,message",
    [
        ({"positions": [[0, 2]] * 10, "schedule": [2] + [None] * 9}, "schedule[0]: sensor 2 is out of range"),
        ({"positions": [[0, 2]] * 3, "schedule": [None] * 3}, "positions: must have horizon = 10 entries"),
        ("not json", "invalid JSON: Expecting value at line 1"),
    ],
)
def test_evaluate_bad_plans_exit_2(capsys, tmp_path, plan, message):
    p = tmp_path / "plan.json"
    p.write_text(plan if isinstance(plan, str) else json.dumps(plan))
    code, out, err = run_cli(capsys, "evaluate", CASE, str(p))
    assert code == 2 and out == ""
    assert message in one_line_error(err)


def test_evaluate_missing_files_exit_2(capsys, tmp_path):
    code, _, err = run_cli(capsys, "evaluate", str(tmp_path / "none.json"), PLAN)
    assert code == 2 and "no such file" in one_line_error(err)
    code, _, err = run_cli(capsys, "evaluate", CASE, str(tmp_path / "none.json"))
    assert code == 2 and "no such file" in one_line_error(err)


def test_generate_set_is_deterministic(capsys, tmp_path):
    for out_dir in ("a", "b"):
        assert run_cli(capsys, "generate", "--sensors", "3", "--horizon", "8", "--count", "4", "--seed", "5", "--out", str(tmp_path / out_dir))[0] == 0
    a = sorted((tmp_path / "a").iterdir())
    b = sorted((tmp_path / "b").iterdir())
    assert len(a) == 4 and [p.read_text() for p in a] == [p.read_text() for p in b]
    assert voiopt.load(a[0]).n_sensors == 3
    code, out, _ = run_cli(capsys, "generate", "--sensors", "2", "--rho", "0.2", "0.3", "--power", "0.01")
    inst = voiopt.core.instance.from_dict(json.loads(out))
    assert all(0.2 <= s.rho <= 0.3 and s.power_w == 0.01 for s in inst.sensors)



def test_generate_refuses_to_replace_other_instances_of_the_same_name(capsys, tmp_path):
    """File names depend on N, T and the seed alone: another --rho must not replace a set."""
    args = ["generate", "--sensors", "2", "--horizon", "6", "--count", "2", "--seed", "1", "--out", str(tmp_path)]
    assert run_cli(capsys, *args)[0] == 0
    before = {p.name: p.read_text() for p in tmp_path.iterdir()}
    assert run_cli(capsys, *args)[0] == 0  # the same set again: nothing changes
    assert {p.name: p.read_text() for p in tmp_path.iterdir()} == before
    code, _, err = run_cli(capsys, *args, "--rho", "0.2", "0.3")
    line = one_line_error(err)
    assert code == 2 and "--out" in line and "already holds another instance" in line
    assert {p.name: p.read_text() for p in tmp_path.iterdir()} == before  # nothing written
    assert run_cli(capsys, *args, "--rho", "0.2", "0.3", "--overwrite")[0] == 0
    after = {p.name: voiopt.load(p) for p in tmp_path.iterdir()}
    assert after.keys() == before.keys() and all(0.2 <= s.rho <= 0.3 for i in after.values() for s in i.sensors)


def test_generate_out_ending_in_json_is_the_file_itself(capsys, tmp_path):
    """``--out net.json`` writes that file (not a folder of that name), refuses to replace
    another instance there, and a set of several networks still needs a folder."""
    target = tmp_path / "net.json"
    args = ["generate", "--sensors", "2", "--horizon", "6", "--seed", "4", "--links", "bernoulli:0.7"]
    code, out, _ = run_cli(capsys, *args, "--out", str(target))
    assert code == 0 and target.is_file() and str(target) in out
    assert voiopt.load(target) == voiopt.generate(2, 6, seed=4, links={"model": "bernoulli", "success": 0.7})
    before = target.read_text()
    code, _, err = run_cli(capsys, *args[:-3], "5", "--out", str(target))
    assert code == 2 and "already holds another instance" in one_line_error(err) and target.read_text() == before
    assert run_cli(capsys, *args[:-3], "5", "--out", str(target), "--overwrite")[0] == 0
    assert voiopt.load(target) == voiopt.generate(2, 6, seed=5)
    code, _, err = run_cli(capsys, "generate", "--count", "2", "--out", str(tmp_path / "set.json"))
    assert code == 2 and "a folder, not the file" in one_line_error(err) and not (tmp_path / "set.json").exists()

@pytest.mark.parametrize(
    "argv,message",
    [
        (["generate", "--sensors", "0"], "sensors: must be an integer >= 1"),
        (["generate", "--count", "3"], "--count: 3 networks need --out DIR, a folder"),
        (["generate", "--rho", "0.5", "2"], "rho: must be a range"),
        (["solve", CASE, "--method", "nope"], "method: unknown method 'nope'"),
        (["solve", CASE, "--time-limit", "-1"], "--time-limit: must be a number of seconds > 0"),
    ],
)
def test_bad_options_exit_2(capsys, argv, message):
    code, _, err = run_cli(capsys, *argv)
    assert code == 2 and message in one_line_error(err)


def test_usage_errors_are_one_line(capsys):
    with pytest.raises(SystemExit) as e:
        main(["solve", CASE, "--objective", "max-voi"])
    assert e.value.code == 2
    assert "invalid choice: 'max-voi'" in one_line_error(capsys.readouterr().err)


def test_installed_command_has_no_traceback(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"horizon": 3,}')
    proc = subprocess.run([sys.executable, "-m", "voiopt", "validate", str(bad)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert one_line_error(proc.stderr).endswith("invalid JSON: Expecting property name enclosed in double quotes at line 1, column 15")


def test_demo_prints_the_case_study_metrics(capsys):
    code, out, _ = run_cli(capsys, "demo")
    assert code == 0 and "case-study" in out and "mean-min-voi" in out


def test_the_demo_merges_a_method_s_seeds_only_where_they_agree():
    """As the README shows it: "aoi-qlearning (seed 0..2)" where every seed gave the same plan's
    metrics, a row per seed where they differ."""
    from voiopt.core.result import Result
    from voiopt.experiments.demo import _merged

    def res(v, t=1.0):
        return Result("case-study", "qlearning", "mean-min-voi", "feasible", v, None, None, t, None,
                      {"min-voi": 1.0, "mean-min-voi": v, "max-aoi": 3, "mean-max-aoi": 2.0})

    rows = _merged([("dp", res(9.0)), ("qlearning (seed 0)", res(5.0)), ("qlearning (seed 1)", res(4.0)),
                    ("aoi-qlearning (seed 0)", res(3.0, 0.5)), ("aoi-qlearning (seed 1)", res(3.0, 0.7))])
    assert [(label, [r.runtime_s for r in runs]) for label, runs in rows] == [
        ("dp", [1.0]), ("qlearning (seed 0)", [1.0]), ("qlearning (seed 1)", [1.0]),
        ("aoi-qlearning (seed 0..1)", [0.5, 0.7])]


def test_evaluate_and_warm_start_name_the_plan_file_and_refuse_another_instance_s_result(capsys, tmp_path):
    result = tmp_path / "case.json"
    assert run_cli(capsys, "solve", CASE, "--method", "greedy", "--quiet", "-o", str(result))[0] == 0
    dock = str(Path(CASE).with_name("dock.json"))
    code, _, err = run_cli(capsys, "evaluate", dock, str(result))
    assert code == 2 and one_line_error(err).endswith(f'{result}: a result for instance "case-study", not for "dock"')
    for argv in (["evaluate", CASE, dock], ["solve", CASE, "--method", "dp", "--quiet", "--warm-start", dock]):
        code, _, err = run_cli(capsys, *argv)
        assert code == 2 and f"{dock}: an instance, not a plan" in one_line_error(err)
    plan = json.loads(result.read_text())["plan"]
    plan["positions"][1] = [4.0, 4.0]
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(plan))
    code, _, err = run_cli(capsys, "evaluate", CASE, str(bad))
    assert code == 2 and one_line_error(err).startswith(f"voiopt: error: {bad}: positions[1]: [4, 4] is not one")
    code, _, err = run_cli(capsys, "solve", CASE, "--method", "dp", "--quiet", "--warm-start", str(bad))
    assert code == 2 and one_line_error(err).startswith(f"voiopt: error: --warm-start: {bad}: positions[1]: [4, 4]")
    assert run_cli(capsys, "evaluate", CASE, str(result))[0] == 0  # its own instance: fine


def test_a_plan_or_result_given_as_an_instance_and_a_missing_command_get_one_line(capsys, tmp_path):
    plan = tmp_path / "p.json"
    plan.write_text(json.dumps(CASE_STUDY_PLAN))
    result = tmp_path / "r.json"
    assert run_cli(capsys, "solve", CASE, "--method", "greedy", "--quiet", "-o", str(result))[0] == 0
    for path, what in ((plan, "a plan"), (result, "a result JSON")):
        code, _, err = run_cli(capsys, "validate", str(path))
        assert code == 2 and one_line_error(err) == (f"{path}: {what}, not an instance (an instance has area, "
                                                     "horizon, sensors and start)")
    with pytest.raises(SystemExit) as e:
        main([])
    line = one_line_error(capsys.readouterr().err)
    assert e.value.code == 2 and line.startswith("voiopt: error: give a command: validate, evaluate,") and "solve" in line


def test_an_option_a_method_does_not_take_is_named_in_the_callers_words(capsys):
    """The command line lists its flags (only those the method takes), Python its keywords."""
    code, _, err = run_cli(capsys, "solve", CASE, "--gap", "0.1", "--quiet")  # dp, the default, has no MIP gap
    line = one_line_error(err)
    assert code == 2 and line == ("voiopt: error: --gap: not an option of method 'dp' (on the command line it takes "
                                  "--time-limit, --memory-limit, --warm-start, --threads)")
    with pytest.raises(voiopt.OptionError, match=r"^time_limt: not an option of method 'greedy' "
                                                 r"\(it takes time_limit, memory_limit\)$"):
        voiopt.solve(voiopt.load(CASE), "greedy", time_limt=1)


def test_the_default_method_is_dp_and_milp_for_three_robots(capsys, tmp_path):
    three = tmp_path / "three.json"
    code, text, _ = run_cli(capsys, "generate", "--sensors", "2", "--horizon", "5", "--robots", "3", "--seed", "3")
    assert code == 0
    three.write_text(text)
    for path, method in ((CASE, "dp"), (three, "milp")):
        out = tmp_path / f"{method}.json"
        assert run_cli(capsys, "solve", str(path), "--quiet", "-o", str(out))[0] == 0
        r = voiopt.load_result(out)
        assert r.method == method and r.status == "optimal"
    assert voiopt.solve(voiopt.load(three)).method == "milp" and voiopt.solve(voiopt.case_study()).method == "dp"


# ------------------------------------------------ options and outputs checked before any work


@pytest.mark.parametrize("argv, says", [
    (["generate", "--seed", "-1"], "argument --seed: must be an integer >= 0, got '-1'"),
    (["generate", "--count", "0"], "argument --count: must be an integer >= 1, got '0'"),
    (["solve", CASE, "--method", "qlearning", "--seed", "-2"], "argument --seed: must be an integer >= 0"),
    (["gap-report", CASE, "--methods", "qlearning", "--episodes", "0", "-o", "{tmp}/r"],
     "argument --episodes: must be an integer >= 1, got '0'"),
    (["figures", "--out", "{tmp}/f", "--seed", "-1"], "argument --seed: must be an integer >= 0"),
    (["gap-report", CASE, "--methods", "greedy", "--dask-scheduler", "garbage", "-o", "{tmp}/r"],
     "--dask-scheduler: 'garbage' is no scheduler address"),
    (["bench", "certify", "--work", "{tmp}/w", "--dask-scheduler", "tcp://nohost.invalid:8786", "--into", "{tmp}"],
     "--dask-scheduler: 'tcp://nohost.invalid:8786' is no scheduler address"),  # a name that never resolves
    (["bench", "certify", "--work", "{tmp}/w/v", "--only", "nosuch"], "--only: 'nosuch' is no VoI-Lib"),
    (["bench", "certify", "--work", "{tmp}/w", "--threads", "0", "--only", "case-study", "--into", "{tmp}"],
     "--threads: must be an integer from 1 to 256, got 0"),
    (["bench", "certify", "--work", "{tmp}/w", "--threads", "1.5", "--only", "case-study", "--into", "{tmp}"],
     "argument --threads: must be an integer, got '1.5'"),  # worded as solve's --threads
    (["solve", CASE, "--method", "milp", "--threads", "2147483648", "-o", "{tmp}/r.json"],
     "--threads: must be an integer from 1 to 256, got 2147483648"),  # HiGHS ignored it; the result recorded it
    (["bench", "certify", "--work", "{tmp}/w", "--time-limit", "0", "--only", "case-study", "--into", "{tmp}"],
     "--time-limit: must be a number of seconds > 0, got 0.0"),
    (["bench", "certify", "--work", "{tmp}/w", "--into", "{tmp}/a-file", "--only", "case-study"],
     "--into: '{tmp}/a-file' is a file, not a folder"),
    (["solve", CASE, "--method", "greedy", "-o", ""], "-o/--output: give a name, not an empty one"),
    (["solve", CASE, "--method", "greedy", "-o", "{tmp}/" + "a" * 237 + ".json"], "is longer than 241 bytes"),
    (["solve", CASE, "--method", "greedy", "-o", "{tmp}/a-file/r.json"], "a-file' in "),
    (["generate", "--count", "2", "--out", ""], "--out: give a name, not an empty one"),
    (["generate", "--count", "200000", "--out", "{tmp}/nets"], "--count: at most 100000 networks in one set"),
    (["generate", "--dock"], "--dock: starts the robots around robot 0's start; give --robots K with K >= 2"),
    (["gap-report", CASE, "--methods", "qlearning", "--episodes", "1e100", "-o", "{tmp}/r"],
     "--episodes: must be an integer from 1 to 1e+12, got 1e+100"),  # not a folder of failed runs
    (["solve", CASE, "--method", "qlearning", "--episodes", "1e13", "-o", "{tmp}/r.json"],
     "episodes: must be an integer from 1 to 1e+12, got 10000000000000"),
    (["solve", CASE, "--method", "qlearning", "--episodes", "1000000000001", "-o", "{tmp}/r.json"],
     "episodes: must be an integer from 1 to 1e+12, got 1000000000001"),
])
def test_bad_options_and_outputs_are_one_line_before_any_work(capsys, tmp_path, argv, says):
    (tmp_path / "a-file").write_text("x")
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    try:
        code = main(argv)
    except SystemExit as e:  # argparse's own errors
        code = e.code
    err = capsys.readouterr().err
    assert code == 2 and says.replace("{tmp}", str(tmp_path)) in one_line_error(err), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file"]  # nothing made, nothing run


def test_long_names_and_large_seeds_are_kept(capsys, tmp_path):
    """An output name that fits beside its temporary file (241 bytes) is written; a seed beyond
    2**53 is used as written, not rounded through a float."""
    out = tmp_path / ("a" * 236 + ".json")
    assert run_cli(capsys, "solve", CASE, "--method", "greedy", "-o", str(out), "--quiet")[0] == 0 and out.exists()
    code, text, _ = run_cli(capsys, "generate", "--seed", "9007199254740993")
    assert code == 0 and json.loads(text)["name"] == "n4-t30-seed9007199254740993"


def test_nested_output_folders_are_made_where_a_command_makes_them(tmp_path):
    from voiopt.runtime.files import check_output_dir

    assert check_output_dir(tmp_path / "a" / "b", "--work", parents=True) == tmp_path / "a" / "b"
    (tmp_path / "f").write_text("x")
    with pytest.raises(voiopt.VoioptError, match="is a file, not a folder"):
        check_output_dir(tmp_path / "f" / "a" / "b", "--work", parents=True)
    with pytest.raises(voiopt.VoioptError, match="does not exist"):
        check_output_dir(tmp_path / "c" / "d", "--out")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f"]  # checked, not made


def test_sweeps_check_their_seed_and_episodes_in_the_api_too(tmp_path):
    from voiopt.experiments.gaps import gap_report

    for bad in (dict(seed=-1), dict(episodes=0)):
        with pytest.raises(voiopt.VoioptError, match="seed: must be|--episodes: must be"):
            gap_report([CASE], ["greedy"], "mean-min-voi", tmp_path / "r", **bad)
    assert not (tmp_path / "r").exists()


def test_generator_seeds_and_counts_are_checked_by_the_api():
    with pytest.raises(voiopt.VoioptError, match="seed: must be an integer >= 0, got -1"):
        voiopt.generate(seed=-1)
    with pytest.raises(voiopt.VoioptError, match="count: must be an integer from 1 to 100000"):
        voiopt.generate_set(100_001)
    assert voiopt.generate(seed=3).to_dict() == voiopt.generate(seed=3).to_dict()


def test_plot_names_the_file_of_a_result_it_cannot_read(capsys, tmp_path):
    result = tmp_path / "r.json"
    assert run_cli(capsys, "solve", CASE, "--method", "greedy", "-o", str(result), "--quiet")[0] == 0
    d = json.loads(result.read_text())
    for objective in ("foo", None):
        result.write_text(json.dumps({**d, "objective": objective}))
        code, _, err = run_cli(capsys, "plot", str(result), "-o", str(tmp_path / "p.png"))
        assert code == 2 and f"{result}: objective: unknown objective" in one_line_error(err)
    code, _, err = run_cli(capsys, "plot", CASE, "-o", str(tmp_path / "p.png"))
    assert code == 2 and one_line_error(err) == f"voiopt: error: {CASE}: an instance, not a plan " \
                                                "({positions, schedule}) or a result JSON"  # the file named once
    result.write_text("[1, 2]")
    code, _, err = run_cli(capsys, "plot", str(result), "-o", str(tmp_path / "p.png"))
    assert code == 2 and "result: must be a JSON object, got list" in one_line_error(err)
    assert not (tmp_path / "p.png").exists()


def test_bench_export_refuses_a_folder_in_a_file_s_place_before_writing_any(capsys, tmp_path):
    (tmp_path / "certificates.json").mkdir()
    code, _, err = run_cli(capsys, "bench", "export", "--out", str(tmp_path))
    assert code == 2 and "certificates.json' is a directory" in one_line_error(err)
    assert [p.name for p in tmp_path.iterdir()] == ["certificates.json"]  # no instance written either


def test_evaluate_says_when_a_result_has_no_plan(capsys, tmp_path):
    result = tmp_path / "r.json"
    assert run_cli(capsys, "solve", CASE, "--method", "greedy", "-o", str(result), "--quiet")[0] == 0
    d = json.loads(result.read_text())
    del d["plan"]
    result.write_text(json.dumps(d))
    code, _, err = run_cli(capsys, "evaluate", CASE, str(result))
    assert code == 2 and f"{result}: a result without a plan field" in one_line_error(err)


def test_bench_export_keeps_an_edited_copy_unless_told(capsys, tmp_path):
    assert run_cli(capsys, "bench", "export", "--out", str(tmp_path))[0] == 0
    assert run_cli(capsys, "bench", "export", "--out", str(tmp_path))[0] == 0  # the same files again: fine
    mine = tmp_path / "case-study.json"
    edited = json.loads(mine.read_text())
    edited["horizon"] += 1
    mine.write_text(json.dumps(edited))
    before = {p.name: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    code, _, err = run_cli(capsys, "bench", "export", "--out", str(tmp_path))
    assert code == 2 and "case-study.json already holds another instance" in one_line_error(err)
    assert {p.name: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before  # nothing written
    assert run_cli(capsys, "bench", "export", "--out", str(tmp_path), "--overwrite")[0] == 0
    assert json.loads(mine.read_text())["horizon"] == edited["horizon"] - 1


def test_plot_finds_the_instance_beside_the_result_or_in_the_folder_above(capsys, tmp_path, monkeypatch):
    dock = voiopt.load(ROOT / "instances" / "dock.json")
    (tmp_path / "report" / "results").mkdir(parents=True)
    voiopt.save(dock, tmp_path / "report" / "dock.json")
    result = tmp_path / "report" / "results" / "dock__greedy.json"
    voiopt.solve(dock, method="greedy").save(result)
    monkeypatch.chdir(tmp_path)  # no ./instances here
    assert run_cli(capsys, "plot", str(result), "-o", "p.png")[0] == 0 and (tmp_path / "p.png").stat().st_size > 1000
    (tmp_path / "report" / "dock.json").unlink()
    voiopt.solve(dock, method="greedy").save(tmp_path / "dock.json")  # a result named like the instance: not taken for it
    for path in (result, tmp_path / "dock.json"):
        code, _, err = run_cli(capsys, "plot", str(path), "-o", "q.png")
        line = one_line_error(err)
        assert code == 2 and "--instance: give the instance of result 'dock' (no dock.json beside the result" in line
        assert ("but the result itself" in line) == (path.name == "dock.json")


def test_plot_finds_the_instance_in_an_instances_folder_beside_the_result(capsys, tmp_path, monkeypatch):
    """A result saved in a clone's folder, plotted from elsewhere: its instance is in instances/
    beside it (a newcomer probe, 2026-12-03: 'voiopt plot CLONE/fleet-dp.json' was refused)."""
    dock = voiopt.load(ROOT / "instances" / "dock.json")
    (tmp_path / "clone" / "instances").mkdir(parents=True)
    voiopt.save(dock, tmp_path / "clone" / "instances" / "dock.json")
    voiopt.solve(dock, method="greedy").save(tmp_path / "clone" / "dock-greedy.json")
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    code, out, err = run_cli(capsys, "plot", str(tmp_path / "clone" / "dock-greedy.json"), "-o", "p.png")
    assert code == 0 and (tmp_path / "elsewhere" / "p.png").stat().st_size > 1000, err


def test_plot_refuses_a_result_that_its_instance_does_not_give(capsys, tmp_path, monkeypatch):
    """A result solved on an edited copy of the case study (the same name) was drawn on the
    built-in case study, with that network's value and the result's "optimal" in the title; a
    result whose value was edited was drawn as its file said (a review). Both are refused, and
    evaluate notes it."""
    edited = json.loads(Path(CASE).read_text())
    edited["sensors"][0]["rho"] = 0.2
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "rho.json").write_text(json.dumps(edited))
    monkeypatch.chdir(tmp_path)  # no ./instances here
    assert run_cli(capsys, "solve", "in/rho.json", "-o", "r.json", "--quiet")[0] == 0
    code, _, err = run_cli(capsys, "plot", "r.json", "-o", "p.png")
    line = one_line_error(err)
    assert code == 2 and "its plan on the built-in case study does not give what the result says" in line
    assert "--instance" in line and not (tmp_path / "p.png").exists()
    assert run_cli(capsys, "plot", "r.json", "--instance", "in/rho.json", "-o", "p.png")[0] == 0
    code, out, err = run_cli(capsys, "evaluate", CASE, "r.json")
    assert code == 0 and "note: r.json says otherwise (min-voi" in err and "mean-min-voi" in out
    forged = json.loads((tmp_path / "r.json").read_text())
    forged["value"] *= 2
    (tmp_path / "f.json").write_text(json.dumps(forged))
    code, _, err = run_cli(capsys, "plot", "f.json", "--instance", "in/rho.json", "-o", "f.png")
    assert code == 2 and "mean-min-voi" in one_line_error(err) and "stored" in err
    code, _, err = run_cli(capsys, "evaluate", "in/rho.json", "f.json")  # the value alone forged: noted too
    assert code == 0 and "note: f.json says otherwise (mean-min-voi" in err
    forged["metrics"]["max-aoi"] = 10**400  # a JSON integer too large for a float: no traceback
    (tmp_path / "f.json").write_text(json.dumps(forged))
    code, _, err = run_cli(capsys, "evaluate", "in/rho.json", "f.json")
    assert code == 0 and "note: f.json says otherwise (max-aoi an integer of 401 digits" in err and "Traceback" not in err
    code, _, err = run_cli(capsys, "plot", "f.json", "--instance", "in/rho.json", "-o", "f.png")
    assert code == 2 and "max-aoi an integer of 401 digits stored" in one_line_error(err)


def test_a_command_stopped_as_a_whole_says_whether_it_kept_results(capsys, monkeypatch, tmp_path):
    """A stop that ends the whole command (a second Ctrl-C, or one before a solve's stop rule is
    in place) ends it in one line: a sweep keeps the runs it finished, a solve keeps nothing."""
    from voiopt.experiments import gaps
    from voiopt.runtime.stop import Interrupted

    def stopped(*args, **kw):
        raise Interrupted(2)

    monkeypatch.setattr("voiopt.cli.main.instance_mod.load", stopped)
    code, out, err = run_cli(capsys, "solve", CASE, "-o", str(tmp_path / "r.json"))
    assert (code, out) == (130, "")
    assert one_line_error(err) == "voiopt: interrupted (SIGINT); the command did not finish"
    assert not (tmp_path / "r.json").exists()
    monkeypatch.setattr(gaps, "gap_report", stopped)
    code, out, err = run_cli(capsys, "gap-report", CASE, "-o", str(tmp_path / "report"))
    assert (code, out) == (130, "")
    assert one_line_error(err) == "voiopt: interrupted (SIGINT); finished results are kept"


def test_a_progress_line_in_a_log_keeps_its_counts(capsys, tmp_path):
    """Off a terminal the bar's last line is written once, and at 80 columns it was cut to
    '1000000/1…' (a review); it is now as wide as it needs."""
    code, _, err = run_cli(capsys, "solve", CASE, "--method", "qlearning", "--episodes", "123456", "-o", str(tmp_path / "q.json"))
    assert code == 0 and "123456/123456" in err and "greedy" in err


def test_a_progress_line_on_an_80_column_terminal_keeps_its_counts_and_clock(tmp_path):
    """On a terminal 80 columns wide Q-learning's line was cut to 'qlearning ━━━ 1000000/1…':
    the bar gives way now, and the counts, the fields and the clock fit (this line is 80 wide
    with a bar of a few columns)."""
    env = {**os.environ, "COLUMNS": "80", "FORCE_COLOR": "1", "TTY_COMPATIBLE": "1"}  # rich: a terminal
    proc = subprocess.run([sys.executable, "-m", "voiopt", "solve", CASE, "--method", "qlearning", "--episodes", "1e9",
                           "--time-limit", "1", "-o", str(tmp_path / "q.json")], capture_output=True, text=True,
                          env=env, timeout=120)
    frames = [re.sub(r"\x1b\[[0-9;?]*[a-zA-Z]", "", f) for f in re.split(r"[\r\n]", proc.stderr)]
    lines = [f for f in frames if "eps " in f]
    assert proc.returncode == 0 and lines, proc.stderr
    assert all(len(line) <= 80 and re.search(r" \d+/1000000000 eps [\d.]+ greedy \S+ states \d+ \d:\d\d:\d\d$", line)
               for line in lines), lines


def test_plot_draws_a_plan_file_as_evaluate_reads_it(capsys, tmp_path):
    """plot took only results; a plan file, or a submission of a plan with its instance and
    objective (VoI-Lib's form), failed on a missing 'objective' or 'method' (a review)."""
    plan = str(ROOT / "instances" / "case-study.plan.json")
    code, _, err = run_cli(capsys, "plot", plan, "-o", str(tmp_path / "p.png"))
    assert code == 2 and "--instance: give the instance of this plan (it names none)" in one_line_error(err)
    assert run_cli(capsys, "plot", plan, "--instance", CASE, "-o", str(tmp_path / "p.png"))[0] == 0
    assert (tmp_path / "p.png").stat().st_size > 5000
    sub = tmp_path / "sub.json"
    sub.write_text(json.dumps({"instance": "case-study", "objective": "max-aoi", "plan": CASE_STUDY_PLAN}))
    assert run_cli(capsys, "plot", str(sub), "-o", str(tmp_path / "s.png"))[0] == 0  # found by its name
    sub.write_text(json.dumps({"instance": "case-study", "objective": "best", "plan": CASE_STUDY_PLAN}))
    code, _, err = run_cli(capsys, "plot", str(sub), "-o", str(tmp_path / "b.png"))
    assert code == 2 and one_line_error(err).endswith(f'{sub}: objective: must be one of min-voi, mean-min-voi, '
                                                      'max-aoi, mean-max-aoi, got "best"')
    sub.write_text(json.dumps({"instance": "elsewhere", "plan": CASE_STUDY_PLAN}))
    code, _, err = run_cli(capsys, "plot", str(sub), "--instance", CASE, "-o", str(tmp_path / "e.png"))
    assert code == 2 and "the plan is for 'elsewhere', the instance is 'case-study'" in one_line_error(err)


def test_a_warm_start_of_another_instance_names_the_option_and_the_file(capsys, tmp_path):
    other = tmp_path / "dock-result.json"
    voiopt.solve(voiopt.load(ROOT / "instances" / "dock.json"), method="greedy").save(other)
    for path, why in ((other, 'a result for instance "dock"'), (tmp_path / "missing.json", "no such file"),
                      (Path(CASE), "an instance, not a plan")):
        code, _, err = run_cli(capsys, "solve", CASE, "--method", "greedy", "--warm-start", str(path), "--quiet")
        assert code == 2 and one_line_error(err).startswith(f"voiopt: error: --warm-start: {path}: {why}"), err


def test_a_file_is_named_once_and_as_given(capsys, monkeypatch, tmp_path):
    """'--warm-start ./missing.json' read '--warm-start: ./missing.json: missing.json: no such file':
    the reader named the file as a normalised path, so the option's prefix did not recognise it."""
    monkeypatch.chdir(tmp_path)
    code, _, err = run_cli(capsys, "solve", CASE, "--method", "greedy", "--warm-start", "./missing.json", "--quiet")
    assert code == 2 and one_line_error(err) == "voiopt: error: --warm-start: ./missing.json: no such file"
    code, _, err = run_cli(capsys, "solve", "./missing.json", "--quiet")
    assert code == 2 and one_line_error(err) == "voiopt: error: ./missing.json: no such file"


def test_a_seed_beyond_the_random_streams_64_bits_is_refused(capsys):
    """Q-learning's stream keeps 64 bits of the seed: 2**64 would silently rerun seed 0."""
    code, _, err = run_cli(capsys, "solve", CASE, "--method", "qlearning", "--episodes", "10", "--seed", str(2**64))
    assert code == 2 and "seed: must be below 2**64" in one_line_error(err)
    assert run_cli(capsys, "solve", CASE, "--method", "qlearning", "--episodes", "10", "--seed", str(2**64 - 1),
               "--quiet")[0] == 0


def test_a_result_with_an_unknown_status_is_refused(capsys, tmp_path):
    d = voiopt.solve(voiopt.case_study(), method="greedy").to_dict()
    d["status"] = "great"
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(d))
    code, _, err = run_cli(capsys, "plot", str(bad), "-o", str(tmp_path / "x.png"))  # plot draws the status in its title
    assert code == 2 and "status: must be one of optimal" in one_line_error(err) and '"great"' in err
    assert not (tmp_path / "x.png").exists()
