"""The simulator at long horizons against its slot-by-slot form, measured in the same run.

``voiopt.core.simulate.simulate_indices`` computes the ages and distances of every slot at once and,
from 2048 slots on, values each sensor's distinct (age, distance) pairs once. The reference is
the dynamics as MODEL.md section 3 states them: ``advance`` slot by slot, then
``physics.voi`` on every entry. Both value shortest-path's plan; the bits must agree. Also
``check_plan``, which checks the plan first.

    python benchmarks/simulate_speed.py                         # T = 3e5 one robot, 1e5 three
    python benchmarks/simulate_speed.py --cases 1000000:1
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import voiopt
from voiopt.core.simulate import check_plan, simulate_indices, slot_by_slot


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", default="300000:1,100000:3", help="T:robots, comma-separated")
    ap.add_argument("--sensors", type=int, default=4)
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args(argv)
    print("| T | robots | slot by slot s | simulate_indices s | ratio | check_plan s | same bits |")
    print("|---:|---:|---:|---:|---:|---:|---|")
    for case in args.cases.split(","):
        T, K = (int(x) for x in case.split(":"))
        inst = voiopt.generate(args.sensors, T, seed=5, robots=K)
        plan = voiopt.solve(inst, "shortest-path").plan
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            idx, sched = check_plan(inst, plan)
            t_check = time.perf_counter() - t0
            t0 = time.perf_counter()
            ref = slot_by_slot(inst, idx, sched)[2]
            t_ref = time.perf_counter() - t0
            t0 = time.perf_counter()
            new = simulate_indices(inst, idx, sched).voi
            t_new = time.perf_counter() - t0
            same = np.array_equal(ref.view(np.int64), new.view(np.int64))
            print(f"| {T:,} | {K} | {t_ref:.2f} | {t_new:.3f} | {t_ref / t_new:.0f}x | {t_check:.2f} | {same} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
