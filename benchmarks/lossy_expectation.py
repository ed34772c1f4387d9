"""A plan's exact expected objectives under lossy links against the simulator and Monte Carlo,
measured in the same run.

``voiopt.core.expectation.expected_metrics`` values a greedy plan of N = 4 sensors exactly
(bernoulli links, p = 0.7); the ratio is its time over one lossless simulation of the same plan,
and over a Monte Carlo estimate of ``mean-min-voi`` with ``--samples`` scenarios, which gives only
an estimate (its 95 % CI half-width is shown against the exact value's error, which is none).

    python benchmarks/lossy_expectation.py                      # T = 30, 100, 300, 1000
    python benchmarks/lossy_expectation.py --horizons 30 --samples 10000
"""

from __future__ import annotations

import argparse
import sys
import time

import voiopt
from voiopt.core.expectation import expected_metrics
from voiopt.core.instance import from_dict
from voiopt.core.scenarios import monte_carlo, sample_scenarios


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--horizons", default="30,100,300,1000", help="T, comma-separated")
    ap.add_argument("--sensors", type=int, default=4)
    ap.add_argument("--samples", type=int, default=1000, help="Monte Carlo scenarios")
    args = ap.parse_args(argv)
    print("| T | uploads | simulate s | exact s | exact / simulate | Monte Carlo s | exact / MC | MC CI half-width / exact |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    for T in (int(x) for x in args.horizons.split(",")):
        inst = voiopt.generate(args.sensors, T, seed=3)
        plan = voiopt.solve(inst, "greedy").plan
        lossy = from_dict(inst.to_dict() | {"links": {"model": "bernoulli", "success": 0.7}})
        t0 = time.perf_counter()
        voiopt.simulate(inst, plan)
        t_sim = time.perf_counter() - t0
        t0 = time.perf_counter()
        exact = expected_metrics(lossy, plan)["mean-min-voi"]
        t_exact = time.perf_counter() - t0
        scen = sample_scenarios(lossy, args.samples, seed=0)
        t0 = time.perf_counter()
        est = monte_carlo(lossy, plan, scen, "mean-min-voi")
        t_mc = time.perf_counter() - t0
        uploads = sum(u is not None for u in plan.schedule)
        half = (est.ci[1] - est.ci[0]) / 2
        print(f"| {T} | {uploads} | {t_sim:.4f} | {t_exact:.3f} | {t_exact / t_sim:.0f} | {t_mc:.3f} | "
              f"{t_exact / t_mc:.2f} | {half / exact:.2%} |", flush=True)
    return 0


if __name__ == "__main__":
    import report

    sys.exit(report.run("lossy_expectation", main))
