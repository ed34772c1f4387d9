"""Where Q-learning's time goes as epsilon falls: the kernel alone, timed chunk by chunk.

    .venv/bin/python benchmarks/qlearning_phases.py [--network K] [--episodes 1000000] [--chunks 20]

One network of the speed benchmark (benchmarks/qlearning_speed.py: random N = 4, T = 30,
generator seed 0; or others by --sensors, --horizon, --size and --network-seed), the paper's Algorithm 1 on a hash
table sized in advance (no growth, no progress bar, no rollouts), timed in equal chunks of
episodes: CPU seconds and million steps per second per chunk, beside epsilon and the states
stored so far. Exploring steps (epsilon near 1) reach new and rarely visited states, so they
wait on memory; greedy steps late in training follow a path in cache. The last line sums the
exploring phase (the first half of the chunks) and the rest.

To compare two trees, run it with PYTHONPATH=TREE for each, alternating, several times: on a
shared VM one pair says little (docs/qlearning.md, "Where a step waits").
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

import voiopt
from voiopt.mdp import robot as mdp
from voiopt.solvers import qlearning as ql


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--network", type=int, default=0, help="which of the generated networks (default 0)")
    ap.add_argument("--network-seed", type=int, default=0, help="the generator's seed (default 0)")
    ap.add_argument("--sensors", type=int, default=4)
    ap.add_argument("--horizon", type=int, default=30)
    ap.add_argument("--size", type=float, default=5.0, help="width and height in metres (default 5)")
    ap.add_argument("--episodes", type=int, default=1_000_000)
    ap.add_argument("--chunks", type=int, default=20)
    ap.add_argument("--slots", type=int, default=1 << 23, help="hash slots, sized in advance (default 2^23)")
    ap.add_argument("--seed", type=int, default=0, help="Q-learning's seed (default 0)")
    args = ap.parse_args()

    inst = voiopt.generate_set(args.network + 1, seed=args.network_seed, n_sensors=args.sensors, horizon=args.horizon,
                               width=args.size, height=args.size)[args.network]
    model = mdp.build(inst)
    ql.warm_up()  # compile, or load numba's cache, outside the timing
    table = ql.QTable(model, 0.0, None, slots=args.slots)
    eps, rng = np.array([1.0]), np.array([ql.seed_state(args.seed)], dtype=np.uint64)
    per_chunk = args.episodes // args.chunks
    print(f"{inst.name}: {model.n_words}-word keys, {args.episodes} episodes in {args.chunks} chunks, "
          f"{len(table.table):,} slots; load average {os.getloadavg()[0]:.2f}")
    print(f"{'chunk':>5} {'epsilon':>8} {'cpu s':>7} {'M steps/s':>10} {'states':>10}")
    times = []
    for c in range(args.chunks):
        t0 = time.process_time()
        done, fits = ql.train(model, table, per_chunk, eps, 1.0 / args.episodes, ql.BETA, ql.GAMMA, rng)
        times.append(time.process_time() - t0)
        if not fits:
            sys.exit(f"the table of {len(table.table):,} slots is too small: give --slots")
        print(f"{c:>5} {eps[0]:>8.2f} {times[-1]:>7.3f} {per_chunk * inst.horizon / times[-1] / 1e6:>10.1f} "
              f"{table.n_states:>10,}")
    half = args.chunks // 2
    print(f"total {sum(times):.2f} s cpu: exploring phase (first {half} chunks) {sum(times[:half]):.2f} s, "
          f"the rest {sum(times[half:]):.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
