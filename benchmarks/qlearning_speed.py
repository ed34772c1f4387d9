"""Q-learning speed: the compiled kernel against plain-Python Algorithm 1, same process.

    .venv/bin/python benchmarks/qlearning_speed.py [--episodes 1000000] [--networks 3]

Paper defaults (R_max = 1e6, beta 0.75, gamma 0.9) on random N = 4, T = 30 networks. Prints
steps per second of each (wall clock, whole solve including rollouts), the ratio, the wall and
CPU time of each full solve and the peak memory. On a shared machine compare the CPU column.
Targets (issue 4): ratio >= 100, 1e6 episodes < 10 s on one core, peak memory < 2 GiB.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from reference_qlearning import reference_qlearning  # noqa: E402

import voiopt  # noqa: E402
from voiopt.models import mdp  # noqa: E402
from voiopt.solvers import qlearning as ql  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=1_000_000, help="R_max of the compiled runs")
    ap.add_argument("--reference-episodes", type=int, default=3000, help="episodes of the plain-Python run")
    ap.add_argument("--networks", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    networks = voiopt.generate_set(args.networks, seed=args.seed, n_sensors=4, horizon=30)
    T = networks[0].horizon
    # compile (or load the numba cache) outside the timings: solve, and a tiny table that must grow
    ql.solve(networks[0], episodes=10)
    ql.train(mdp.build(networks[0]), ql.QTable(mdp.build(networks[0]), 0.0, 64, slots=16), 20,
             np.array([1.0]), 0.05, ql.BETA, ql.GAMMA, np.array([1], dtype=np.uint64))
    print("load average (1, 5, 15 min): {:.2f} {:.2f} {:.2f} on {} CPUs".format(*os.getloadavg(), os.cpu_count()))

    model = mdp.build(networks[0])
    t0 = time.perf_counter()
    reference_qlearning(model, args.reference_episodes, seed=args.seed)
    ref_s = time.perf_counter() - t0  # wall, like the compiled runs: both see the same load
    ref_rate = args.reference_episodes * T / ref_s
    print(f"plain Python  {args.reference_episodes} episodes on {networks[0].name}: "
          f"{ref_s:.2f} s, {ref_rate:,.0f} steps/s")
    table = ql.QTable(model, 0.0, 1536)
    eps, rng = np.array([1.0]), np.array([ql.seed_state(args.seed)], dtype=np.uint64)
    t0 = time.perf_counter()
    ql.train(model, table, args.reference_episodes, eps, 1.0 / args.reference_episodes, ql.BETA, ql.GAMMA, rng)
    same_s = time.perf_counter() - t0
    print(f"compiled kernel, the same {args.reference_episodes} episodes: {same_s:.4f} s, "
          f"{args.reference_episodes * T / same_s:,.0f} steps/s, ratio {ref_s / same_s:.0f}x")

    print(f"{'network':<22} {'episodes':>9} {'wall s':>7} {'cpu s':>7} {'steps/s':>12} {'ratio':>7} {'states':>9} "
          f"{'table MiB':>9}  value (mean-min-voi)")
    rates, walls = [], []
    for inst in networks:
        t0, c0 = time.perf_counter(), time.process_time()
        r = ql.solve(inst, "mean-min-voi", episodes=args.episodes, seed=args.seed)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        rate = r.solver["episodes_run"] * T / wall
        rates.append(rate)
        walls.append(wall)
        print(f"{inst.name:<22} {r.solver['episodes_run']:>9} {wall:>7.2f} {cpu:>7.2f} {rate:>12,.0f} "
              f"{rate / ref_rate:>7.0f} {r.solver['table_states']:>9} {r.solver['table_mib']:>9.1f}  {r.value:.6g}")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux
    mean_rate = sum(rates) / len(rates)
    print(f"compiled mean {mean_rate:,.0f} steps/s; ratio to plain Python {mean_rate / ref_rate:.0f}x "
          f"(target >= 100x); wall per {args.episodes} episodes: max {max(walls):.2f} s (target < 10 s); "
          f"peak memory {peak:.0f} MiB (target < 2048 MiB)")
    print("load average (1, 5, 15 min): {:.2f} {:.2f} {:.2f}".format(*os.getloadavg()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
