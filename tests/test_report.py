"""Gap reports: the table, resume, failures, and the Dask path."""

from __future__ import annotations

import csv
import json
import os

import pytest

import voiopt
from voiopt import objectives
from voiopt.cli.main import main
from voiopt.experiments import gaps as report
from voiopt.experiments import runner
from voiopt.networks.generate import generate_set, write_set


@pytest.fixture(scope="module")
def nets(tmp_path_factory):
    folder = tmp_path_factory.mktemp("nets")
    write_set(generate_set(3, seed=21, n_sensors=2, horizon=6, width=2, height=2, rho=(0.2, 0.9)), folder)
    return folder


def read_rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


@pytest.mark.parametrize("objective", ["mean-min-voi", "max-aoi"])
def test_gap_table_matches_result_files(tmp_path, nets, objective):
    methods = ["dp", "milp", "greedy", "shortest-path"]
    report.gap_report([nets], methods, objective, tmp_path)
    rows = read_rows(tmp_path / "gaps.csv")
    assert len(rows) == 3 * len(methods)
    assert list(rows[0]) == report.GAP_COLUMNS
    maximise = voiopt.OBJECTIVES[objective] == "max"
    for row in rows:
        r = voiopt.load_result(tmp_path / "results" / f"{row['instance']}__{row['method']}.json")
        assert (row["status"], float(row["value"])) == (r.status, r.value)
        same = [x for x in rows if x["instance"] == row["instance"]]
        values = [float(x["value"]) for x in same]
        assert float(row["best_value"]) == (max(values) if maximise else min(values))
        best_bound = float(row["best_bound"])
        if row["method"] in ("dp", "milp"):
            assert row["status"] == "optimal"
            assert float(row["gap"]) == pytest.approx(0, abs=1e-9)
        else:
            v = float(row["value"])
            expected = (best_bound - v) / best_bound if maximise else (v - best_bound) / best_bound
            assert float(row["gap"]) == pytest.approx(expected, rel=1e-12, abs=1e-15)
    summary = (tmp_path / "summary.md").read_text()
    assert "| dp | 3 | - | 3 | 3 | 0 |" in summary
    assert (tmp_path / "gaps.png").stat().st_size > 1000


def test_resume_after_interrupt_redoes_nothing(tmp_path, nets, monkeypatch):
    real = runner.solver_function
    calls = []

    def flaky(method):
        fn = real(method)

        def wrapped(inst, objective, **kw):
            calls.append((inst.name, method))
            if len(calls) == 4:
                raise KeyboardInterrupt
            return fn(inst, objective, **kw)

        return wrapped

    monkeypatch.setattr(runner, "solver_function", flaky)
    with pytest.raises(KeyboardInterrupt):
        report.gap_report([nets], ["greedy", "shortest-path"], "mean-min-voi", tmp_path)
    done = sorted((tmp_path / "results").glob("*.json"))
    assert len(done) == 3, "the three finished pairs are on disk"
    before = {p.name: p.stat().st_mtime_ns for p in done}
    calls.clear()
    monkeypatch.setattr(runner, "solver_function", real)
    report.gap_report([nets], ["greedy", "shortest-path"], "mean-min-voi", tmp_path)
    after = sorted((tmp_path / "results").glob("*.json"))
    assert len(after) == 6
    assert all(p.stat().st_mtime_ns == before[p.name] for p in after if p.name in before)
    assert len(read_rows(tmp_path / "gaps.csv")) == 6


def test_a_failing_pair_is_recorded_and_the_sweep_goes_on(tmp_path, nets, monkeypatch):
    real = runner.solver_function

    def broken(method):
        if method == "greedy":
            def fail(inst, objective, **kw):
                raise ValueError("solver exploded")
            return fail
        return real(method)

    monkeypatch.setattr(runner, "solver_function", broken)
    rows = report.gap_report([nets], ["greedy", "shortest-path"], "mean-min-voi", tmp_path)
    errors = [r for r in rows if r["status"] == "error"]
    assert len(errors) == 3 and all(r["method"] == "greedy" and r["value"] is None for r in errors)
    r = voiopt.load_result(tmp_path / "results" / f"{errors[0]['instance']}__greedy.json")
    assert r.solver["error"] == "ValueError: solver exploded"
    assert sum(r["status"] == "feasible" for r in rows) == 3
    assert "| greedy | 3 | - | 3 | 0 | 3 |" in (tmp_path / "summary.md").read_text()


def _comparable(path):
    return [{k: v for k, v in row.items() if k != "runtime_s"} for row in read_rows(path)]


def _plans(folder):
    return {p.name: json.loads(p.read_text())["plan"] for p in sorted((folder / "results").glob("*.json"))}


def test_dask_local_cluster_matches_process_pool(tmp_path, nets):
    methods = ["dp", "greedy"]
    report.gap_report([nets], methods, "mean-min-voi", tmp_path / "pool", workers=2)
    report.gap_report([nets], methods, "mean-min-voi", tmp_path / "dask", workers=1, dask_scheduler="local")
    assert _comparable(tmp_path / "pool" / "gaps.csv") == _comparable(tmp_path / "dask" / "gaps.csv")
    assert _plans(tmp_path / "pool") == _plans(tmp_path / "dask")


def test_dask_workers_elsewhere_and_a_relative_output_write_on_the_client(tmp_path, nets, monkeypatch):
    """Workers run in another working directory (as on a cluster without a shared filesystem);
    a relative -o must be written by the client, in the client's directory, and nowhere else."""
    from distributed import Client, LocalCluster

    client_dir, worker_dir = tmp_path / "client", tmp_path / "worker"
    client_dir.mkdir()
    worker_dir.mkdir()
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \
            Client(cluster) as client:
        client.run(os.chdir, str(worker_dir))
        assert set(client.run(os.getcwd).values()) == {str(worker_dir)}
        monkeypatch.chdir(client_dir)
        code = main(["gap-report", str(nets), "--methods", "dp,greedy", "--dask-scheduler", cluster.scheduler_address,
                     "--memory-limit", "2", "-o", "rel-out", "--quiet"])
    assert code == 0
    assert (client_dir / "rel-out" / "gaps.csv").is_file()
    assert len(list((client_dir / "rel-out" / "results").glob("*.json"))) == 3 * 2
    assert list(worker_dir.rglob("*")) == []  # nothing written on the worker's side


@pytest.mark.parametrize(
    "argv,message",
    [
        (["--methods", "dp,nope"], "--methods: unknown method 'nope'"),
        (["--methods", "dp,dp"], "--methods: a method is repeated"),
        (["--workers", "0", "--methods", "greedy"], "--workers: must be an integer >= 1"),
        (["--workers", "1000000", "--methods", "greedy"], "--workers: at most "),  # had started thousands of processes
        (["--time-limit", "-2"], "--time-limit: must be a number of seconds > 0"),
    ],
)
def test_bad_options_exit_2(capsys, tmp_path, nets, argv, message):
    code = main(["gap-report", str(nets), "-o", str(tmp_path), "--quiet", *argv])
    err = capsys.readouterr().err
    assert code == 2 and message in err and len(err.strip().splitlines()) == 1


def test_the_report_folder_is_also_given_as_out_like_the_other_folder_commands(tmp_path, nets):
    assert main(["gap-report", str(nets), "--methods", "greedy", "--out", str(tmp_path / "r"), "--quiet"]) == 0
    assert len(read_rows(tmp_path / "r" / "gaps.csv")) == 3


def test_missing_instances_exit_2(capsys, tmp_path):
    code = main(["gap-report", str(tmp_path / "none"), "-o", str(tmp_path), "--quiet"])
    assert code == 2 and "no such file or folder" in capsys.readouterr().err


@pytest.mark.parametrize("content", ["[1, 2]", '"x"', '{"seed": 1, "seed": 1}', "{"])
def test_a_run_json_that_is_not_a_runs_settings_is_refused_in_one_line(tmp_path, nets, capsys, content):
    """A run.json that is valid JSON but not an object gave an AttributeError traceback; an
    unreadable one was reported as other settings ('a differs'). Both now say what it is (a
    review, 2026-12-02)."""
    (tmp_path / "run.json").write_text(content)
    code = main(["gap-report", str(nets), "-o", str(tmp_path), "--quiet", "--methods", "greedy"])
    err = capsys.readouterr().err
    assert code == 2 and "holds a run.json that is not a voiopt run's settings" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_resume_refuses_a_folder_made_with_other_settings(tmp_path, nets, capsys):
    report.gap_report([nets], ["greedy"], "mean-min-voi", tmp_path, seed=1)
    with pytest.raises(voiopt.OptionError, match=r"holds a run with other settings \(seed differs\)"):
        report.gap_report([nets], ["greedy"], "mean-min-voi", tmp_path, seed=2)
    # adding a method to the same experiment is a resume, not a conflict
    rows = report.gap_report([nets], ["greedy", "shortest-path"], "mean-min-voi", tmp_path, seed=1)
    assert len(rows) == 6
    code = main(["gap-report", str(nets), "-o", str(tmp_path), "--quiet", "--methods", "greedy", "--objective", "max-aoi", "--seed", "1"])
    assert code == 2 and "(objective differs)" in capsys.readouterr().err


def test_randomised_methods_run_once_per_seed_through_the_cli(tmp_path, nets):
    out = tmp_path / "seeds"
    code = main(["gap-report", str(nets), "--methods", "dp,qlearning,greedy", "--episodes", "2e3",
                 "--seed", "5", "--seeds", "3", "-o", str(out), "--quiet"])
    assert code == 0
    rows = read_rows(out / "gaps.csv")
    assert "seed" in rows[0]
    insts = {r["instance"] for r in rows}
    for name in insts:
        q = [r for r in rows if r["instance"] == name and r["method"] == "qlearning"]
        assert sorted(int(r["seed"]) for r in q) == [5, 6, 7]
        for r in q:  # each value is the simulator's value of its saved plan
            res = voiopt.load_result(out / "results" / f"{name}__qlearning__seed{r['seed']}.json")
            assert res.solver["seed"] == int(r["seed"]) and res.solver["reward_units"] == "bit/s"
            inst = voiopt.load(nets / f"{name}.json")
            assert float(r["value"]) == voiopt.evaluate(inst, res.plan)["mean-min-voi"]
        for m in ("dp", "greedy"):
            [row] = [r for r in rows if r["instance"] == name and r["method"] == m]
            assert row["seed"] == ""
    summary = (out / "summary.md").read_text()
    gaps = [float(r["gap"]) for r in rows if r["method"] == "qlearning"]
    line = next(line for line in summary.splitlines() if line.startswith("| qlearning |"))
    cells = [c.strip() for c in line.strip("|").split("|")]
    assert cells[1:4] == [str(len(insts)), "5-7", str(3 * len(insts))]
    assert cells[7:10] == [objectives.show_gap(sum(gaps) / len(gaps)), objectives.show_gap(min(gaps)),
                           objectives.show_gap(max(gaps))]
    assert "bit/s, idle penalty 100" in summary
    assert "Q-learning: 2000 episodes per run" in summary  # a report made with fewer episodes says so
    assert {r["reward_units"] for r in rows if r["method"] == "qlearning"} == {"bit/s"}  # the CSV says its reading too
    assert {r["reward_units"] for r in rows if r["method"] != "qlearning"} == {""}
    within = sum(g <= 0.01 for g in gaps)
    assert cells[11] == f"{within}/{len(gaps)}"
    # the bit/s/Hz reading is another experiment: not mixed into the same folder
    assert main(["gap-report", str(nets), "--methods", "qlearning", "--reward-units", "bit/s/Hz",
                 "-o", str(out), "--quiet"]) == 2


def test_a_changed_instance_of_the_same_name_is_run_again_not_reused(tmp_path, nets):
    """A resume reuses a stored result only for the instance it was made from: an instance
    file replaced by another of the same name (another rho, here) is solved again, by every
    method, also one that a later resume adds back."""
    folder = tmp_path / "nets"
    write_set(generate_set(2, seed=21, n_sensors=2, horizon=6, width=2, height=2, rho=(0.2, 0.9)), folder)
    out = tmp_path / "report"
    both = ["greedy", "shortest-path"]
    first = {(r["instance"], r["method"]): r for r in report.gap_report([folder], both, "mean-min-voi", out)}
    name, other = sorted({n for n, _ in first})
    changed = voiopt.generate(2, 6, width=2, height=2, seed=21, rho=(0.95, 0.99), name=name)
    write_set([changed], folder)  # the same file name, other content
    notes: list[str] = []
    again = {(r["instance"], r["method"]): r for r in report.gap_report([folder], ["greedy"], "mean-min-voi", out,
                                                                          notes=notes)}
    assert again[name, "greedy"]["value"] == pytest.approx(voiopt.solve(changed, "greedy").value, rel=1e-12)
    assert again[name, "greedy"]["value"] != first[name, "greedy"]["value"]
    assert again[other, "greedy"]["value"] == first[other, "greedy"]["value"]  # the unchanged instance is reused
    assert any(name in n and "changed" in n for n in notes)
    assert name in (out / "summary.md").read_text()
    last = {(r["instance"], r["method"]): r for r in report.gap_report([folder], both, "mean-min-voi", out)}
    fresh = voiopt.solve(changed, "shortest-path")  # its old result went with the change, though not run then
    assert last[name, "shortest-path"]["value"] == pytest.approx(fresh.value, rel=1e-12)
    assert last[other, "shortest-path"]["value"] == first[other, "shortest-path"]["value"]


def test_a_report_with_no_exact_method_says_there_is_no_gap(tmp_path, nets):
    """Without dp or milp no bound is proven: 'within 1 %' read 0/3, as if every run were far
    from optimal (a review). It now reads '-', and the summary says why."""
    report.gap_report([nets], ["greedy", "shortest-path"], "mean-min-voi", tmp_path)
    summary = (tmp_path / "summary.md").read_text()
    line = next(line for line in summary.splitlines() if line.startswith("| greedy |"))
    cells = [c.strip() for c in line.strip("|").split("|")]
    assert cells[7:12] == ["-"] * 5 and "No method proved a bound" in summary


def test_the_reading_of_v_is_given_only_where_the_reward_has_v():
    """aoi-qlearning's reward is the age alone: its rows read no reward_units (they read bit/s)."""
    from voiopt.core.result import Result

    def res(method, reward):
        return Result("n", method, "mean-min-voi", "feasible", 1.0, None, None, 0.1, None,
                      {"mean-min-voi": 1.0}, {"reward": reward, "reward_units": "bit/s"})

    rows = report.gap_rows([res("qlearning", "voi"), res("aoi-qlearning", "aoi")], "mean-min-voi", [0, 0])
    assert [r["reward_units"] for r in rows] == ["bit/s", ""]


def test_a_pool_has_no_more_processes_than_runs_to_do(tmp_path, nets, monkeypatch):
    """--workers above the number of runs started a process per run up to --workers (a probe's
    --workers 1000000 started thousands); the pool now has at most one per run to do."""
    sizes = []
    make = runner.make_executor

    def recorded(workers, dask_scheduler):
        sizes.append(workers)
        return make(workers, dask_scheduler)

    monkeypatch.setattr(runner, "make_executor", recorded)
    most = runner.WORKERS_PER_CPU * (os.cpu_count() or 1)
    report.gap_report([nets], ["greedy"], "mean-min-voi", tmp_path / "r", workers=most)
    assert sizes == [min(most, 3)]
