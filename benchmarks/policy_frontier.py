"""Where the exact optimal policy (--method policy-dp) ends: states valued and seconds, for
the two averaged objectives, against the horizon, on the case study (N = 3) and a paper-scale
network (N = 4, generated with seed 3), both with bernoulli links of success 0.7. Each run
has a time limit (default 60 s); a run that hits it is reported as such.

    python benchmarks/policy_frontier.py [--time-limit S] [--horizons 6 8 10 ...]
"""

from __future__ import annotations

import argparse
import time

import voiopt
from voiopt.core.instance import from_dict
from voiopt.networks.generate import generate

LINKS = {"model": "bernoulli", "success": 0.7}


def networks():
    yield "case-study (N=3)", voiopt.load("instances/case-study.json").to_dict()
    yield "paper seed 3 (N=4)", generate(4, 30, seed=3, name="paper").to_dict()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--time-limit", type=float, default=60.0)
    ap.add_argument("--horizons", type=int, nargs="+", default=[6, 8, 10, 12, 14])
    args = ap.parse_args()
    print("| network | objective | T | status | states | seconds | value | lossless bound |")
    print("|---|---|---|---|---|---|---|---|")
    for name, d in networks():
        for objective in ("mean-min-voi", "mean-max-aoi"):
            for T in args.horizons:
                inst = from_dict(d | {"horizon": T, "links": LINKS})
                t0 = time.perf_counter()
                r = voiopt.solve(inst, "policy-dp", objective, time_limit=args.time_limit)
                s = time.perf_counter() - t0
                print(f"| {name} | {objective} | {T} | {r.status} | {r.solver['states']} | {s:.1f} | {r.value:.6g} | "
                      f"{r.solver['lossless']['bound']:.6g} |", flush=True)
                if r.status != "optimal":
                    break


if __name__ == "__main__":
    main()
