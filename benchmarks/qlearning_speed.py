"""Q-learning speed: the compiled kernel against plain-Python Algorithm 1, same run.

    .venv/bin/python benchmarks/qlearning_speed.py [--episodes 1000000] [--networks 3]

Paper defaults (R_max = 1e6, beta 0.75, gamma 0.9) on random N = 4, T = 30 networks. Prints
the wall and CPU time of each full solve in this process (including rollouts and table
growth), steps per second, the ratio to the plain-Python reference (run before and after the
compiled runs; the faster run counts, so the ratio is conservative), the peak memory and the
load average. On a shared machine the CPU-time ratio is the steadier one; wall time also
counts waiting.

Then the command as a user runs it, process start-up included: for each network a fresh
``voiopt solve NETWORK.json --method qlearning --episodes E --seed S -o RESULT`` (the CLI of
the voiopt this script imports, ``python -m voiopt``), and the ratio of its steps per wall
second (all networks' steps over all their wall time) to the reference's steps per wall
second; the same ratio per network against plain-Python runs timed just before and just after
it (the faster counts), which a drift of the VM's speed during the run moves less; and the
start-up of a second run: ``--episodes 10``, wall time, numba's cache warm.
With ``--equal-work``, the plain-Python reference also runs the same episodes as the command
line on the first network (about 5 minutes and 1.5 GiB at 1e6 episodes), and the ratio of the
two wall times is printed: the reference's rate at the paper's scale, where its dict holds
millions of states, not the few thousand of its short runs.
Targets (issue 15, item 4): ratio >= 150 including start-up, a second run starting well
under a second; (issue 4) 1e6 episodes < 10 s on one core, peak memory < 2 GiB.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402

import voiopt  # noqa: E402
from voiopt.mdp import robot as mdp  # noqa: E402
from voiopt.solvers import qlearning as ql  # noqa: E402
from voiopt.solvers.qlearning.reference import reference_qlearning  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=1_000_000, help="R_max of the compiled runs")
    ap.add_argument("--reference-episodes", type=int, default=3000, help="episodes of the plain-Python run")
    ap.add_argument("--networks", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--equal-work", action="store_true",
                    help="also time plain Python on the first network's full run (slow: minutes)")
    args = ap.parse_args()

    networks = voiopt.generate_set(args.networks, seed=args.seed, n_sensors=4, horizon=30)
    T = networks[0].horizon
    # compile (or load the numba cache) outside the timings: solve, and a tiny table that must grow
    ql.solve(networks[0], episodes=10)
    ql.train(mdp.build(networks[0]), ql.QTable(mdp.build(networks[0]), 0.0, 64, slots=16), 20,
             np.array([1.0]), 0.05, ql.BETA, ql.GAMMA, np.array([1], dtype=np.uint64))
    print("load average (1, 5, 15 min): {:.2f} {:.2f} {:.2f} on {} CPUs".format(*os.getloadavg(), os.cpu_count()))

    model = mdp.build(networks[0])

    def reference() -> tuple[float, float]:
        t0, c0 = time.perf_counter(), time.process_time()
        reference_qlearning(model, args.reference_episodes, seed=args.seed)
        return time.perf_counter() - t0, time.process_time() - c0

    ref_wall, ref_cpu = reference()
    print(f"plain Python  {args.reference_episodes} episodes on {networks[0].name}: wall {ref_wall:.2f} s, "
          f"cpu {ref_cpu:.2f} s, {args.reference_episodes * T / ref_cpu:,.0f} steps per cpu second")
    table = ql.QTable(model, 0.0, 1536)
    eps, rng = np.array([1.0]), np.array([ql.seed_state(args.seed)], dtype=np.uint64)
    c0 = time.process_time()
    ql.train(model, table, args.reference_episodes, eps, 1.0 / args.reference_episodes, ql.BETA, ql.GAMMA, rng)
    same_cpu = time.process_time() - c0
    print(f"compiled kernel, the same {args.reference_episodes} episodes (small table, mostly new states): "
          f"cpu {same_cpu:.4f} s, ratio {ref_cpu / same_cpu:.0f}x")

    print(f"{'network':<22} {'episodes':>9} {'wall s':>7} {'cpu s':>7} {'steps/wall s':>13} {'steps/cpu s':>12} "
          f"{'states':>9} {'table MiB':>9}  value (mean-min-voi)")
    walls, cpus, steps = [], [], 0
    for inst in networks:
        t0, c0 = time.perf_counter(), time.process_time()
        r = ql.solve(inst, "mean-min-voi", episodes=args.episodes, seed=args.seed)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        n = r.solver["episodes_run"] * T
        walls.append(wall)
        cpus.append(cpu)
        steps += n
        print(f"{inst.name:<22} {r.solver['episodes_run']:>9} {wall:>7.2f} {cpu:>7.2f} {n / wall:>13,.0f} "
              f"{n / cpu:>12,.0f} {r.solver['table_states']:>9} {r.solver['table_mib']:>9.1f}  {r.value:.6g}")
    # the reference again, after: on a shared machine the load changes; keep its faster run
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux, this process only
    cli_steps, cli_walls, startups, paired = command_line(networks, args, lambda: reference()[0])
    ref_wall2, ref_cpu2 = reference()
    ref_wall, ref_cpu = min(ref_wall, ref_wall2), min(ref_cpu, ref_cpu2)
    ref_steps = args.reference_episodes * T
    print(f"plain Python again: wall {ref_wall2:.2f} s, cpu {ref_cpu2:.2f} s; the faster of the two runs is the reference "
          f"({ref_steps / ref_wall:,.0f} steps per wall second, {ref_steps / ref_cpu:,.0f} per cpu second)")
    print(f"command line, start-up included: {cli_steps / sum(cli_walls):,.0f} steps per wall second, "
          f"ratio {cli_steps / sum(cli_walls) / (ref_steps / ref_wall):.0f}x to plain Python in wall time "
          f"(target >= 150x); second-run start-up (--episodes 10) "
          f"{' '.join(f'{s:.2f}' for s in startups)} s wall, best {min(startups):.2f} s")
    print(f"command line, each run paired with the plain-Python runs just before and after it (the faster counts; "
          f"on a VM whose speed drifts, the steadier ratio): {', '.join(f'{r:.0f}x' for r in paired)}, "
          f"median {float(np.median(paired)):.0f}x (target >= 150x)")
    print(f"ratio to plain Python {steps / sum(cpus) / (ref_steps / ref_cpu):.0f}x in cpu time "
          f"({steps / sum(walls) / (ref_steps / ref_wall):.0f}x in wall time) (target >= 100x); "
          f"per {args.episodes} episodes: wall max {max(walls):.2f} s, cpu max {max(cpus):.2f} s (target < 10 s); "
          f"peak memory {peak:.0f} MiB (target < 2048 MiB)")
    if args.equal_work:
        t0 = time.perf_counter()
        reference_qlearning(model, args.episodes, seed=args.seed)
        full = time.perf_counter() - t0
        print(f"equal work: plain Python, {args.episodes} episodes on {networks[0].name}: wall {full:.1f} s "
              f"({args.episodes * T / full:,.0f} steps per wall second); the command line's run of the same network "
              f"{cli_walls[0]:.2f} s, ratio {full / cli_walls[0]:.0f}x (target >= 150x)")
    print("load average (1, 5, 15 min): {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    return 0


def command_line(networks, args, reference) -> tuple[int, list[float], list[float], list[float]]:
    """Time ``voiopt solve`` in fresh processes: (steps, wall seconds per network, wall seconds
    of three --episodes 10 runs, each network's ratio to the faster of the plain-Python runs
    (``reference()``, wall seconds) just before and just after it). The voiopt run is the one
    this script imports: the command runs in its tree's folder (until 2026-12-03 it ran in the
    caller's, and ``python -m`` takes a voiopt there before PYTHONPATH's)."""
    root = str(Path(voiopt.__file__).resolve().parent.parent)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([root, *filter(None, [os.environ.get("PYTHONPATH")])])}
    command = [sys.executable, "-m", "voiopt", "solve"]
    steps, walls, startups = 0, [], []
    with tempfile.TemporaryDirectory() as tmp:
        def run(inst, episodes: int) -> tuple[float, dict]:
            path, out = Path(tmp) / f"{inst.name}.json", Path(tmp) / f"{inst.name}-result.json"
            voiopt.save(inst, path)
            out.unlink(missing_ok=True)
            t0 = time.perf_counter()
            done = subprocess.run([*command, str(path), "--method", "qlearning", "--episodes", str(episodes),
                                   "--seed", str(args.seed), "-o", str(out)], env=env, capture_output=True, text=True,
                                  cwd=root)  # python -m puts its folder first: a voiopt there would win over PYTHONPATH
            wall = time.perf_counter() - t0
            if done.returncode:
                sys.exit(f"{' '.join(done.args)} failed ({done.returncode}):\n{done.stderr}")
            return wall, json.loads(out.read_text())

        print(f"{'command line':<22} {'episodes':>9} {'wall s':>7} {'steps/wall s':>13}  (python -m voiopt solve ..., "
              "process start-up included)")
        ref_steps = args.reference_episodes * networks[0].horizon
        rates, refs = [], [reference()]
        for inst in networks:
            wall, result = run(inst, args.episodes)
            refs.append(reference())
            n = result["solver"]["episodes_run"] * inst.horizon
            steps += n
            walls.append(wall)
            rates.append(n / wall)
            print(f"{inst.name:<22} {result['solver']['episodes_run']:>9} {wall:>7.2f} {n / wall:>13,.0f}  "
                  f"(startup_s {result['solver']['startup_s']:.2f}; plain Python before and after: "
                  f"{ref_steps / refs[-2]:,.0f} and {ref_steps / refs[-1]:,.0f} steps per wall second)")
        paired = [rate / (ref_steps / min(before, after)) for rate, before, after in zip(rates, refs[:-1], refs[1:], strict=True)]
        for _ in range(3):
            startups.append(run(networks[0], 10)[0])
    return steps, walls, startups, paired


if __name__ == "__main__":
    sys.exit(main())
