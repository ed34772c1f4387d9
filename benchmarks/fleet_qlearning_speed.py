"""Q-learning for several robots (MODEL.md section 10): episodes per second and table size.

    .venv/bin/python benchmarks/fleet_qlearning_speed.py [--episodes 20000]

Random N = 4, T = 30 networks on the paper's 6 x 6 lattice (generator seed 1) with two robots
in opposite corners, plain, with ends, with ends and budgets of 12, and three robots; then one
robot on the same network for comparison. Prints each solve's runtime (the joint mask's
construction included, numba compilation not), episodes per second, table states and MiB,
and the load average. docs/qlearning.md quotes a run.
"""

from __future__ import annotations

import argparse
import os

import voiopt
from voiopt.core.instance import from_dict


def fleet(robots: list[dict]) -> voiopt.Instance:
    d = voiopt.generate(4, 30, width=5.0, height=5.0, seed=1, name="fleet-speed").to_dict()
    del d["start"]
    return from_dict({**d, "robots": robots})


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=20000)
    args = ap.parse_args()
    ends = lambda b=None: [{"start": c, "end": c, **({"max_moves": b} if b else {})} for c in ([0, 0], [5, 5])]  # noqa: E731
    cases = {
        "two robots": fleet([{"start": [0, 0]}, {"start": [5, 5]}]),
        "two robots, ends": fleet(ends()),
        "two robots, ends, budgets 12": fleet(ends(12)),
        "three robots": fleet([{"start": [0, 0]}, {"start": [5, 5]}, {"start": [0, 5]}]),
        "one robot": voiopt.generate(4, 30, width=5.0, height=5.0, seed=1, name="one-robot"),
    }
    voiopt.solve(cases["two robots, ends"], method="qlearning", episodes=10)  # compile or load the kernels
    for name, inst in cases.items():
        r = voiopt.solve(inst, method="qlearning", episodes=args.episodes)
        print(f"{name}: {args.episodes} episodes in {r.runtime_s:.2f} s, {args.episodes / r.runtime_s:,.0f} episodes/s, "
              f"{r.solver['table_states']} states, {r.solver['table_mib']:.0f} MiB, mean-min-voi {r.value:.6g}")
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
