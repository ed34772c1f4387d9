"""docs/reliability.md, finding by finding, through the command line as a user runs it: real
subprocesses, real signals, real files."""

from __future__ import annotations

import json
import os
import pty
import select
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

import voiopt
from voiopt.experiments import runner
from voiopt.networks.generate import case_study_plan, generate_set, write_set

ROOT = Path(__file__).resolve().parent.parent
CASE = str(ROOT / "instances" / "case-study.json")


def voiopt_cmd(*args: str, **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "voiopt", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=kw.pop("cwd", ROOT), **kw)


def run(*args: str, timeout: float = 120, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "voiopt", *args], capture_output=True, text=True,
                          timeout=timeout, cwd=kw.pop("cwd", ROOT), **kw)


def wait_until_watching(proc: subprocess.Popen, timeout: float = 60) -> None:
    """Until the process catches SIGTERM: its stop rule is installed (Linux /proc)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            status = Path(f"/proc/{proc.pid}/status").read_text()
        except FileNotFoundError:
            break
        caught = int(next(line for line in status.splitlines() if line.startswith("SigCgt:")).split()[1], 16)
        if caught & (1 << (signal.SIGTERM - 1)):
            return
        time.sleep(0.05)
    raise AssertionError(f"the process never installed its stop rule: {proc.communicate(timeout=5)}")


def wait_until_solving(proc: subprocess.Popen, cpu_s: float = 2.0) -> None:
    """Until a solve is past its start-up: every command catches SIGTERM from its start
    (``stop.sigterm_raises``), before the solve's stop rule, so ``wait_until_watching`` alone
    let a signal land while numba loaded (flaky under load, 2026-12-03). Start-up takes under a
    second of CPU once numba's cache is warm (``warm_qlearning``); so wait for ``cpu_s`` of the
    process's CPU time, which a busy machine delays but does not fake."""
    wait_until_watching(proc)
    tick = os.sysconf("SC_CLK_TCK")
    end = time.monotonic() + 60
    while time.monotonic() < end:
        try:
            fields = Path(f"/proc/{proc.pid}/stat").read_text().rsplit(")", 1)[1].split()
        except FileNotFoundError:
            return
        if (int(fields[11]) + int(fields[12])) / tick >= cpu_s:  # utime + stime
            return
        time.sleep(0.05)
    raise AssertionError(f"the solve used less than {cpu_s} s of CPU in 60 s")


@pytest.fixture
def warm_qlearning():
    """numba's cache of the Q-learning kernels, filled (a fresh clone compiles them once)."""
    voiopt.solve(voiopt.case_study(), method="qlearning", episodes=10)


def one_line(stderr: str) -> str:
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


@pytest.fixture(scope="module", autouse=True)
def compiled_kernels():
    """Compile (or load) numba's kernels once here, so that the subprocesses below time their
    work, not a cold compilation (minutes on a fresh clone's first run)."""
    tiny = voiopt.generate(2, 3, width=1, height=1, seed=0)
    for method in ("dp", "qlearning"):
        voiopt.solve(tiny, method=method, episodes=10) if method == "qlearning" else voiopt.solve(tiny, method=method)


@pytest.fixture(scope="module")
def nets(tmp_path_factory):
    folder = tmp_path_factory.mktemp("nets")
    write_set(generate_set(2, seed=3, n_sensors=3, horizon=10, width=3, height=3), folder)
    return folder


# ------------------------------------------------------------------------------ stopping


@pytest.mark.parametrize("sig, code, workers", [(signal.SIGINT, 130, "1"), (signal.SIGTERM, 143, "2"), (signal.SIGHUP, 129, "2")])
def test_a_signal_stops_the_whole_sweep_keeps_what_finished_and_stores_no_interrupted_run(
        tmp_path, nets, sig, code, workers):
    out = tmp_path / "report"
    proc = voiopt_cmd("gap-report", str(nets), "--methods", "greedy,qlearning", "--episodes", "1e9",
                      "--seeds", "3" if workers == "2" else "1", "--workers", workers, "-o", str(out), "--quiet",
                      preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_DFL))  # even if pytest runs under nohup
    wait_until_watching(proc)
    end = time.monotonic() + 60
    while not list(out.glob("results/*greedy*.json")) and time.monotonic() < end:
        time.sleep(0.1)
    time.sleep(1.0)  # a Q-learning run is under way
    t0 = time.monotonic()
    proc.send_signal(sig)
    _, stderr = proc.communicate(timeout=30)
    assert proc.returncode == code and time.monotonic() - t0 < 3, time.monotonic() - t0  # 5 s (the grace) with runs queued in the pool
    assert "interrupted" in one_line(stderr)
    stored = sorted(p.name for p in (out / "results").glob("*.json"))
    assert stored and all("greedy" in name for name in stored)  # no Q-learning run stored
    assert not (out / "gaps.csv").exists()  # the report is not made from a partial sweep


def test_a_dead_worker_ends_the_sweep_with_one_line(tmp_path, nets):
    out = tmp_path / "report"
    proc = voiopt_cmd("gap-report", str(nets), "--methods", "qlearning", "--episodes", "1e9", "--seeds", "1",
                      "--workers", "2", "-o", str(out), "--quiet")
    wait_until_watching(proc)
    end = time.monotonic() + 60
    workers = []
    while not workers and time.monotonic() < end:
        children = Path(f"/proc/{proc.pid}/task/{proc.pid}/children").read_text().split()
        workers = [int(c) for c in children]
        time.sleep(0.2)
    time.sleep(1.0)
    os.kill(workers[0], signal.SIGKILL)
    _, stderr = proc.communicate(timeout=30)
    assert proc.returncode == 1 and "a worker process died" in one_line(stderr)


def test_a_sweep_killed_outright_takes_its_workers_with_it(tmp_path, nets):
    """SIGKILL (the OOM killer) of a sweep left its pool workers running their solves, then the
    runs queued to them, orphaned: hours at --episodes 1e9 (2026-12-03)."""
    proc = voiopt_cmd("gap-report", str(nets), "--methods", "qlearning", "--episodes", "1e9", "--seeds", "3",
                      "--workers", "2", "-o", str(tmp_path / "report"), "--quiet")
    wait_until_watching(proc)
    end = time.monotonic() + 60
    workers: list[int] = []
    while len(workers) < 2 and time.monotonic() < end:
        workers = [int(c) for c in Path(f"/proc/{proc.pid}/task/{proc.pid}/children").read_text().split()]
        time.sleep(0.2)
    time.sleep(2.0)  # solving
    proc.kill()
    proc.wait(timeout=30)  # not communicate(): orphaned workers would hold its pipes open

    def running(pid: int) -> bool:
        try:
            return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
        except FileNotFoundError:
            return False

    end = time.monotonic() + 10
    alive = workers
    while alive and time.monotonic() < end:
        alive = [w for w in workers if running(w)]
        time.sleep(0.1)
    for w in alive:  # the test leaves nothing running, even when it fails
        os.kill(w, signal.SIGKILL)
    proc.stdout.close()
    proc.stderr.close()
    assert len(workers) == 2 and not alive, (workers, alive)


def test_a_stored_interrupted_run_is_not_done(tmp_path):
    r = voiopt.solve(voiopt.case_study(), method="greedy")
    r.status = "interrupted"
    r.save(tmp_path / "r.json")
    assert not runner.is_done(tmp_path / "r.json")
    r.status = "time_limit"
    r.save(tmp_path / "r.json")
    assert runner.is_done(tmp_path / "r.json")


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_an_interrupted_solve_exits_non_zero_and_keeps_its_best_plan(tmp_path, sig, code, warm_qlearning):
    out = tmp_path / "r.json"
    proc = voiopt_cmd("solve", CASE, "--method", "qlearning", "--episodes", "1e9", "-o", str(out), "--quiet")
    wait_until_solving(proc)
    proc.send_signal(sig)
    _, stderr = proc.communicate(timeout=20)
    assert proc.returncode == code, stderr
    assert f"the best plan so far is written to {out}" in one_line(stderr)
    result = voiopt.load_result(out)
    assert result.status == "interrupted" and result.value == voiopt.evaluate(voiopt.case_study(), result.plan)[result.objective]


def test_a_solve_whose_terminal_hangs_up_keeps_its_best_plan(tmp_path, warm_qlearning):
    """An ssh connection that drops: the terminal hangs up, the process gets SIGHUP and every
    write to the terminal fails. The solve stops as on Ctrl-C, writes its -o file and exits 129
    (until 2026-12-03 SIGHUP killed it and nothing was written)."""
    out = tmp_path / "r.json"
    pid, fd = pty.fork()  # the child leads a session whose controlling terminal is the pty
    if pid == 0:
        try:
            os.chdir(ROOT)
            signal.signal(signal.SIGHUP, signal.SIG_DFL)  # as a login shell's, even if pytest runs under nohup
            os.execv(sys.executable, [sys.executable, "-m", "voiopt", "solve", CASE, "--method", "qlearning",
                                      "--episodes", "1e9", "-o", str(out)])
        finally:
            os._exit(127)
    seen = b""
    end = time.monotonic() + 60
    while b" states " not in seen and time.monotonic() < end:  # the progress bar: solving
        if select.select([fd], [], [], 0.2)[0]:
            seen += os.read(fd, 65536)
    assert b" states " in seen, seen[-300:]  # solving, not still starting
    os.close(fd)  # the terminal hangs up
    _, status = os.waitpid(pid, 0)
    assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 129, (status, seen[-300:])
    result = voiopt.load_result(out)
    assert result.status == "interrupted" and result.solver["stopped"].startswith("interrupted by SIGHUP")


def test_a_hang_up_ignored_as_under_nohup_stays_ignored(tmp_path, warm_qlearning):
    out = tmp_path / "r.json"
    proc = voiopt_cmd("solve", CASE, "--method", "qlearning", "--episodes", "1e9", "--time-limit", "4",
                      "-o", str(out), "--quiet", preexec_fn=lambda: signal.signal(signal.SIGHUP, signal.SIG_IGN))
    wait_until_solving(proc)
    proc.send_signal(signal.SIGHUP)
    _, stderr = proc.communicate(timeout=30)
    assert proc.returncode == 0, stderr
    assert voiopt.load_result(out).status == "time_limit"


def test_a_second_ctrl_c_exits_at_once():
    proc = voiopt_cmd("solve", CASE, "--method", "qlearning", "--episodes", "1e9", "--quiet")
    wait_until_watching(proc)
    proc.send_signal(signal.SIGINT)
    proc.send_signal(signal.SIGINT)
    t0 = time.monotonic()
    proc.communicate(timeout=20)
    assert proc.returncode == 130 and time.monotonic() - t0 < 5



STARTING = """
import os, signal, sys
signal.signal(signal.SIGINT, signal.default_int_handler)  # a terminal's process, even if pytest runs in the background
class Interrupt:  # delivers a real Ctrl-C to this process the moment numpy starts to import
    def find_spec(self, name, path=None, target=None):
        if name == "numpy":
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.SIGINT)
sys.meta_path.insert(0, Interrupt())
sys.argv = ["voiopt", "solve", sys.argv[1], "--method", "dp"]
from voiopt.__main__ import run# what the console script runs
run()
"""


def test_a_ctrl_c_while_the_command_starts_ends_it_in_one_line():
    """A Ctrl-C while Python imports the command line (numpy, rich: a third of a second) ends
    it with one line and status 130, not with the traceback of the import it fell in."""
    proc = subprocess.run([sys.executable, "-c", STARTING, CASE], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 130, proc.stderr
    assert one_line(proc.stderr) == "voiopt: interrupted (SIGINT) while starting; nothing was done"
    assert proc.stdout == ""


# -------------------------------------------------------------------------------- limits


def test_time_limits_hold_at_many_sensors(tmp_path):
    inst = tmp_path / "n400.json"
    voiopt.save(voiopt.generate(400, 30, seed=1), inst)  # greedy alone needs about 25 s (N = 200 took under 3 s on a quiet machine)
    for method in ("dp", "greedy"):
        out = tmp_path / f"{method}.json"
        done = run("solve", str(inst), "--method", method, "--time-limit", "3", "-o", str(out), "--quiet", timeout=60)
        assert done.returncode == 0, done.stderr
        r = voiopt.load_result(out)
        assert r.status == "time_limit" and r.runtime_s <= 3 * 1.1 + 1, (method, r.runtime_s)
        assert r.value == voiopt.evaluate(voiopt.load(inst), r.plan)[r.objective]


def test_two_robots_q_learning_on_a_factory_floor_stops_on_time(tmp_path):
    """Two robots with budgets of 80 moves on a 21 x 21 floor: the table of legal joint states
    has 1.3 GB a slot. Building its last slot took 1.6 s and each block of it seconds, between
    two looks at the stop rule: a 1 s limit returned after 8 s, Ctrl-C after 7 (an outside
    probe, 2026-12-03)."""
    inst = tmp_path / "factory2.json"
    voiopt.save(voiopt.generate_set(1, seed=0, preset="factory", robots=2)[0], inst)
    out = tmp_path / "r.json"
    done = run("solve", str(inst), "--method", "qlearning", "--time-limit", "1", "-o", str(out), "--quiet", timeout=120)
    assert done.returncode == 0, done.stderr
    r = voiopt.load_result(out)
    assert r.status == "time_limit" and r.runtime_s <= 1 * 1.1 + 1, r.runtime_s


def test_greedy_stops_inside_a_step_with_thousands_of_sensors_in_range():
    """At 10,000 sensors (about 2,800 in range of a point) one greedy step values 28 million
    (sensor, upload) pairs, 30 s: a 2 s limit ended after 17.7 s. The step now checks the stop
    rule between blocks of them."""
    inst = voiopt.generate(10_000, 5, seed=3)
    r = voiopt.solve(inst, method="greedy", time_limit=0.5)
    assert r.status == "time_limit" and r.runtime_s <= 0.5 * 1.1 + 1, r.runtime_s
    assert "after 0 of 5 slots" in r.solver["stopped"]


@pytest.mark.parametrize("method", ["dp", "qlearning", "milp"])
def test_work_that_cannot_fit_the_memory_limit_is_refused_before_it_starts(tmp_path, method):
    inst = tmp_path / "long.json"
    voiopt.save(voiopt.generate(4, 100_000, width=30, height=30, seed=1), inst)
    done = run("solve", str(inst), "--method", method, "--memory-limit", "1", timeout=60)
    assert done.returncode == 2
    assert "--memory-limit:" in one_line(done.stderr) and "over the limit of 1 GB" in done.stderr


def test_a_memory_limit_stop_is_reported_as_such(tmp_path):
    nets = tmp_path / "nets"
    write_set(generate_set(2, seed=0, n_sensors=4, horizon=30), nets)  # paper scale: tables of GBs at 1e6
    out = tmp_path / "report"
    done = run("gap-report", str(nets), "--methods", "aoi-qlearning", "--episodes", "1e6", "--seeds", "1",
               "--memory-limit", "0.02", "-o", str(out), "--quiet", timeout=120)
    assert done.returncode == 0, done.stderr
    results = [voiopt.load_result(p) for p in (out / "results").glob("*.json")]
    assert {r.status for r in results} == {"memory_limit"}
    assert all("memory limit of 0.02 GB" in r.solver["stopped"] for r in results)
    summary = (out / "summary.md").read_text()
    assert "| 2 memory_limit |" in summary and "memory limit of 0.02 GB reached" in summary


def test_milp_stops_at_its_memory_limit_while_highs_runs(tmp_path):
    """HiGHS's memory is opaque: milp counted only its estimate made before the solve, and a
    solve under --memory-limit 0.05 grew 300 MB and ran to its time limit (an outside probe,
    2026-12-03). The process's resident growth is watched now. A fresh process: in this one,
    freed pages would be reused unseen."""
    inst = tmp_path / "n12.json"
    voiopt.save(voiopt.generate(12, 30, seed=5), inst)
    out = tmp_path / "r.json"
    done = run("solve", str(inst), "--method", "milp", "--memory-limit", "0.05", "--time-limit", "60", "-o", str(out),
               "--quiet", timeout=120)
    assert done.returncode == 0, done.stderr
    r = voiopt.load_result(out)
    assert r.status == "memory_limit" and r.solver["stopped"] == "memory limit of 0.05 GB reached", r.solver
    assert r.runtime_s < 30 and r.value == voiopt.evaluate(voiopt.load(inst), r.plan)[r.objective]


# -------------------------------------------------------------------------------- output


@pytest.mark.parametrize("where, message", [
    ("a-dir", "is a directory"),
    ("missing/r.json", "does not exist"),
])
def test_bad_output_paths_fail_before_any_work(tmp_path, where, message):
    (tmp_path / "a-dir").mkdir()
    t0 = time.monotonic()
    done = run("solve", CASE, "--method", "qlearning", "--episodes", "1e8", "-o", str(tmp_path / where))
    assert done.returncode == 2 and message in one_line(done.stderr) and str(tmp_path / where) in done.stderr
    assert time.monotonic() - t0 < 20  # no 1e8-episode training first


def test_an_unwritable_output_fails_before_any_work(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    unwritable = ro if os.geteuid() != 0 else Path("/sys")  # root may write anywhere but in /sys
    done = run("solve", CASE, "--method", "greedy", "-o", str(unwritable / "r.json"))
    assert done.returncode == 2 and "no permission" in one_line(done.stderr)
    done = run("gap-report", CASE, "--methods", "greedy", "-o", str(unwritable / "report"))
    assert done.returncode == 2 and "no permission" in one_line(done.stderr)


def test_files_get_the_umask_permissions(tmp_path):
    out = tmp_path / "r.json"
    done = run("solve", CASE, "--method", "greedy", "-o", str(out), "--quiet",
               preexec_fn=lambda: os.umask(0o022))
    assert done.returncode == 0
    assert stat.S_IMODE(out.stat().st_mode) == 0o644


def test_instance_names_never_become_paths_outside_the_report(tmp_path):
    nets = tmp_path / "nets"
    nets.mkdir()
    for k, name in enumerate([".hidden", "weird name:*?<>|", "ok"]):  # "/", "..": refused by validation
        inst = voiopt.generate(2, 4, width=2, height=2, seed=k, name=name)
        (nets / f"{k}.json").write_text(json.dumps(inst.to_dict()))
    out = tmp_path / "deep" / "report"
    out.parent.mkdir()
    done = run("gap-report", str(nets), "--methods", "greedy", "-o", str(out), "--quiet")
    assert done.returncode == 0, done.stderr
    written = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*.json") if "nets" not in p.parts)
    assert all(w.startswith("deep/report/") for w in written) and len(written) == 4  # 3 results, run.json
    assert any(w.startswith("deep/report/results/ok__greedy") for w in written)


def test_a_failed_gap_report_does_not_lock_its_folder_and_non_instances_are_skipped(tmp_path, nets):
    folder = tmp_path / "nets"
    folder.mkdir()
    for p in nets.glob("*.json"):
        (folder / p.name).write_text(p.read_text())
    bad = json.loads(next(folder.glob("*.json")).read_text())
    bad["sensors"][0]["rho"] = 1.5
    (folder / "zz-typo.json").write_text(json.dumps(bad))
    (folder / "a-plan.json").write_text(json.dumps(case_study_plan().to_dict()))
    out = tmp_path / "report"
    done = run("gap-report", str(folder), "--methods", "greedy", "-o", str(out), "--quiet")
    assert done.returncode == 2 and "zz-typo.json: sensors[0].rho" in one_line(done.stderr)
    assert not (out / "run.json").exists()
    (folder / "zz-typo.json").unlink()
    done = run("gap-report", str(folder), "--methods", "greedy", "-o", str(out), "--quiet", "--seeds", "2")
    assert done.returncode == 0 and "skipped" in done.stderr and "a-plan.json" in done.stderr
    assert "skipped" in (out / "summary.md").read_text()
    done = run("gap-report", str(ROOT / "instances"), "--methods", "greedy", "-o", str(tmp_path / "r2"), "--quiet")
    assert done.returncode == 0 and "case-study.plan.json: not an instance" in done.stderr


@pytest.mark.parametrize("suffix, magic", [(".png", b"\x89PNG"), (".pdf", b"%PDF"), (".svg", b"<?xml")])
def test_plots_follow_the_suffix(tmp_path, suffix, magic):
    r = voiopt.solve(voiopt.case_study(), method="greedy")
    r.save(tmp_path / "r.json")
    out = tmp_path / f"plot{suffix}"
    assert run("plot", str(tmp_path / "r.json"), "-o", str(out)).returncode == 0
    assert out.read_bytes().startswith(magic)


def test_an_unknown_plot_suffix_is_rejected(tmp_path):
    r = voiopt.solve(voiopt.case_study(), method="greedy")
    r.save(tmp_path / "r.json")
    done = run("plot", str(tmp_path / "r.json"), "-o", str(tmp_path / "x.jpg"))
    assert done.returncode == 2 and ".png, .pdf or .svg" in one_line(done.stderr)
    assert not (tmp_path / "x.jpg").exists()


@pytest.mark.parametrize("args, kept", [([], "not kept (-o FILE keeps it)"), (["--json"], "printed above (--json)")])
def test_an_interrupted_solve_says_where_its_best_plan_went(args, kept, warm_qlearning):
    proc = voiopt_cmd("solve", CASE, "--method", "qlearning", "--episodes", "1e9", *args)
    wait_until_solving(proc)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=20)
    assert proc.returncode == 130, stderr
    assert stderr.splitlines()[-1].endswith(f"the best plan so far is {kept}")
    if args:
        assert json.loads(stdout)["status"] == "interrupted"


def test_a_ctrl_c_while_the_temporary_file_is_made_leaves_no_file(tmp_path, monkeypatch):
    """The temporary file's name is drawn before it is made: an interrupt just after the
    making (before anything could note the name) still removes it."""
    from voiopt.runtime import files

    real_open = os.open

    def open_then_interrupt(path, flags, mode=0o777):
        real_open(path, flags, mode)
        raise KeyboardInterrupt

    monkeypatch.setattr(files.os, "open", open_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        files.write_json_atomic(tmp_path / "r.json", {"a": 1})
    assert list(tmp_path.iterdir()) == []


WRITE_KILLED = """
import os, signal, sys
from voiopt.runtime.files import write_json_atomic
from voiopt.runtime.stop import Interrupted
class Term(dict):  # a result whose writing receives SIGTERM half way
    def items(self):
        os.kill(os.getpid(), signal.SIGTERM)
        return super().items()
try:
    write_json_atomic(sys.argv[1] + "/r.json", {"a": 1, "b": Term(c=2)})
except Interrupted as e:
    print("interrupted", e.exit_code, os.listdir(sys.argv[1]), signal.getsignal(signal.SIGTERM) == signal.SIG_DFL)
"""


def test_a_sigterm_while_a_file_is_written_leaves_no_temporary_file(tmp_path):
    """A SIGTERM whose action is the default one (after a solve's stop rule is gone, as a
    second signal during the write of a result) killed the process mid-write and left the
    temporary .tmp file beside the result (a fuzz campaign). While a file is written it now
    raises Interrupted: the temporary file is removed, and the command ends with status 143."""
    proc = subprocess.run([sys.executable, "-c", WRITE_KILLED, str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.returncode
    assert proc.stdout.split() == ["interrupted", "143", "[]", "True"], proc.stderr


# ------------------------------------------------------------------------------ where outputs go


def test_an_output_that_would_replace_an_input_or_names_a_folder_is_refused(tmp_path):
    """-o onto the command's own input would replace it with the output; -o DIR/ would write a
    file named DIR. Both are refused before any work, in one line, and the input is kept."""
    inst = tmp_path / "cs.json"
    voiopt.save(voiopt.case_study(), inst)
    before = inst.read_bytes()
    done = run("solve", str(inst), "--method", "greedy", "-o", str(inst), "--quiet")
    assert done.returncode == 2 and "is the INSTANCE this command reads" in one_line(done.stderr)
    assert inst.read_bytes() == before
    (tmp_path / "link.json").symlink_to(inst)  # the same file by another name
    done = run("solve", str(inst), "--method", "greedy", "-o", str(tmp_path / "link.json"), "--quiet")
    assert done.returncode == 2 and inst.read_bytes() == before
    done = run("export", str(inst), str(inst))
    assert done.returncode == 2 and inst.read_bytes() == before
    done = run("solve", str(inst), "--method", "greedy", "-o", str(tmp_path / "out") + "/", "--quiet")
    assert done.returncode == 2 and "names a folder" in one_line(done.stderr) and not (tmp_path / "out").exists()


def test_an_output_through_a_link_or_into_a_pipe_keeps_what_the_path_is(tmp_path):
    """A symbolic link stays a link (its target gets the result); a named pipe (like a device,
    /dev/null) is written into, not replaced by a regular file."""
    import threading

    inst = tmp_path / "cs.json"
    voiopt.save(voiopt.case_study(), inst)
    target, link = tmp_path / "target.json", tmp_path / "link.json"
    target.write_text("{}")
    link.symlink_to(target)
    assert run("solve", str(inst), "--method", "greedy", "-o", str(link), "--quiet").returncode == 0
    assert link.is_symlink() and voiopt.load_result(target).method == "greedy"
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()), daemon=True)
    reader.start()
    assert run("solve", str(inst), "--method", "greedy", "-o", str(fifo), "--quiet").returncode == 0
    reader.join(30)
    assert stat.S_ISFIFO(fifo.stat().st_mode) and json.loads(got[0])["method"] == "greedy"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cs.json", "link.json", "pipe", "target.json"]


def test_a_writer_by_file_name_replaces_the_file_only_when_it_finishes(tmp_path):
    """atomic_path (HiGHS writes a model by file name): a write that fails leaves the old file
    and no temporary one; one that finishes replaces it; the temporary name keeps the suffix,
    which picks HiGHS's format."""
    from voiopt.runtime.files import atomic_path

    model = tmp_path / "m.mps"
    model.write_text("OLD")
    with pytest.raises(RuntimeError), atomic_path(model) as tmp:
        assert tmp.suffix == ".mps" and tmp.parent == tmp_path
        tmp.write_text("HALF")
        raise RuntimeError("cut short")
    assert model.read_text() == "OLD" and sorted(p.name for p in tmp_path.iterdir()) == ["m.mps"]
    assert run("export", str(ROOT / "instances" / "case-study.json"), str(model)).returncode == 0
    assert model.read_text().rstrip().endswith("ENDATA") and sorted(p.name for p in tmp_path.iterdir()) == ["m.mps"]


def test_a_sweep_whose_scheduler_is_not_dask_ends_in_one_line_and_leaves_its_folder_free(tmp_path, nets):
    """--dask-scheduler at a service that speaks first and is not Dask (as ssh does) made the
    Dask client read a frame 'length' of exabytes: a traceback. Now one line, exit 2, and the
    run.json written before the run could start is removed, so another run may use the folder."""
    import socket
    import threading

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()

    def banner():
        while True:
            try:
                conn, _ = server.accept()
            except OSError:
                return
            conn.sendall(b"SSH-2.0-OpenSSH_9.6\r\n")

    threading.Thread(target=banner, daemon=True).start()
    out = tmp_path / "report"
    try:
        done = run("gap-report", str(nets), "--methods", "greedy", "-o", str(out), "--quiet",
                   "--dask-scheduler", f"tcp://127.0.0.1:{server.getsockname()[1]}", timeout=60)
    finally:
        server.close()
    assert done.returncode == 2 and "did not answer as a Dask scheduler" in one_line(done.stderr)
    assert not (out / "run.json").exists()
    done = run("gap-report", str(nets), "--methods", "greedy", "-o", str(out), "--quiet", "--time-limit", "5")
    assert done.returncode == 0, done.stderr


def test_an_output_to_dev_stdout_writes_where_the_shell_sends_it(tmp_path):
    """/dev/stdout is a link to the file behind the shell's redirection: the result goes
    through the process's own descriptor, between what the shell wrote before and after it
    (a first fix followed the link and replaced that file, losing 'header')."""
    out = tmp_path / "out.txt"
    command = (f"{{ echo header; {sys.executable} -m voiopt solve {ROOT / 'instances' / 'case-study.json'} "
               f"--method greedy --quiet -o /dev/stdout; echo trailer; }} > {out}")
    assert subprocess.run(["bash", "-c", command], cwd=ROOT, timeout=120).returncode == 0
    lines = out.read_text().splitlines()
    assert lines[0] == "header" and lines[-1] == "trailer"
    assert json.loads("\n".join(lines[1:-1]))["method"] == "greedy"


def test_links_an_output_goes_through_keep_the_format_and_place_the_user_gave(tmp_path):
    """export through m.lp -> real.mps writes LP (the name given picks the format) into real.mps;
    a dangling link is replaced by the file, as a missing file would be made, with no folders
    made along its target."""
    inst = ROOT / "instances" / "case-study.json"
    (tmp_path / "real.mps").write_text("OLD")
    (tmp_path / "m.lp").symlink_to("real.mps")
    assert run("export", str(inst), str(tmp_path / "m.lp")).returncode == 0
    assert (tmp_path / "m.lp").is_symlink() and "HiGHS .lp file" in (tmp_path / "real.mps").read_text()
    (tmp_path / "dl.json").symlink_to("nowhere/deep/out.json")
    assert run("solve", str(inst), "--method", "greedy", "--quiet", "-o", str(tmp_path / "dl.json")).returncode == 0
    assert not (tmp_path / "dl.json").is_symlink() and not (tmp_path / "nowhere").exists()
    assert voiopt.load_result(tmp_path / "dl.json").method == "greedy"


def test_a_sweeps_seeds_past_64_bits_are_refused_before_any_work(tmp_path, nets):
    done = run("gap-report", str(nets), "--methods", "qlearning", "--episodes", "10", "--seed", str(2**64 - 1),
               "--seeds", "2", "-o", str(tmp_path / "q"), "--quiet")
    assert done.returncode == 2 and "must be below 2**64" in one_line(done.stderr) and not (tmp_path / "q").exists()


@pytest.fixture
def silent_scheduler():
    """The address of a service that accepts and never speaks, as an HTTP server waits for the
    client to speak first."""
    import socket
    import threading

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    held = []

    def silent():
        while True:
            try:
                held.append(server.accept()[0])
            except OSError:
                return

    threading.Thread(target=silent, daemon=True).start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    finally:
        server.close()
        for conn in held:
            conn.close()


def test_a_scheduler_address_that_never_answers_ends_in_one_line(monkeypatch, silent_scheduler):
    """--dask-scheduler at a service that waits for the client to speak first (an HTTP server)
    made the Dask client wait in its handshake without end (its connect timeout does not cover
    the handshake): only Ctrl-C ended it. Now a one-line error after SCHEDULER_WAIT_S."""
    from voiopt.errors import OptionError
    from voiopt.experiments import runner

    monkeypatch.setattr(runner, "SCHEDULER_WAIT_S", 1.5)
    t0 = time.perf_counter()
    with pytest.raises(OptionError, match="did not answer as a Dask scheduler within 1.5 s"):
        with runner.make_executor(1, silent_scheduler):
            pass
    assert time.perf_counter() - t0 < 10


def test_a_sigterm_ends_any_command_with_a_line(tmp_path):
    """A command without a stop rule of its own (bench score of thousands of files, here an
    evaluate blocked on a named pipe) ended silently on SIGTERM, killed; it now says so, like
    a Ctrl-C, with status 143 (a probe, 2026-12-03)."""
    pipe = tmp_path / "result.json"
    os.mkfifo(pipe)
    proc = voiopt_cmd("evaluate", str(ROOT / "instances" / "case-study.json"), str(pipe))
    wait_until_watching(proc)
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=30)
    assert proc.returncode == 143 and one_line(stderr) == "voiopt: interrupted (SIGTERM); the command did not finish"


def test_a_stop_while_waiting_for_a_scheduler_ends_the_sweep_as_a_stop(tmp_path, nets, silent_scheduler):
    """After review: a SIGTERM while the client waited for a scheduler that never answers was
    lost (the wait ran its 15 s, then exit 2); it now ends the sweep as a stop, 143."""
    from voiopt.experiments import runner

    proc = voiopt_cmd("gap-report", str(nets), "--methods", "greedy", "-o", str(tmp_path / "r"), "--quiet",
                      "--dask-scheduler", silent_scheduler)
    wait_until_watching(proc)
    time.sleep(1.0)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 143 and "interrupted (SIGTERM)" in one_line(stderr)
    assert time.monotonic() - t0 < runner.SCHEDULER_WAIT_S / 2
    assert runner.check_workers(1000, "tcp://10.0.0.1:8786") == 1000  # a remote cluster's workers are its own
