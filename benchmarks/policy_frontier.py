"""Where the exact optimal policy (--method policy-dp) ends: states valued and seconds, for the
two averaged objectives, against the horizon, on the case study (N = 3) and a paper-scale
network (N = 4, generated with seed 3), both with bernoulli links of success 0.7. Each run has
a time limit (default 60 s); the horizons of a network and objective stop at the first run
that hits it. Writes docs/results/policy_frontier.md (benchmarks/report.py).

Then the paired speed table: on the largest horizon of the list that the plain expectimax
(voiopt/solvers/policy/expectimax.py, the reference) finishes within ``--plain-limit``, the
plain and the layered search (layered.py) on the same instance one after the other, their
seconds, their ratio, and whether their values and on-policy actions are identical.

``--paper-scale`` runs the paper's scale instead (N = 4, T = 30, mean-max-aoi, a longer time
limit) and writes docs/results/policy_frontier_paper_scale.md.

    python benchmarks/policy_frontier.py [--time-limit S] [--horizons 6 8 10 ...] [--plain-limit S]
    python benchmarks/policy_frontier.py --paper-scale [--time-limit S]
"""

from __future__ import annotations

import argparse
import resource
import sys
import time

import voiopt
from voiopt.core.instance import from_dict
from voiopt.networks.generate import generate
from voiopt.runtime.stop import Stop, Stopped
from voiopt.solvers.dp.solver import warm_up as dp_warm_up
from voiopt.solvers.policy.expectimax import Expectimax
from voiopt.solvers.policy.layered import Layered, warm_up

LINKS = {"model": "bernoulli", "success": 0.7}
OBJECTIVES = ("mean-min-voi", "mean-max-aoi")
PAPER = "paper seed 3 (N=4)"


def networks():
    yield "case study (N=3)", voiopt.load("instances/case-study.json").to_dict()
    yield PAPER, generate(4, 30, seed=3, name="paper").to_dict()


def lossy(d: dict, T: int):
    return from_dict(d | {"horizon": T, "links": LINKS})


def frontier(cases, time_limit: float):
    """One row per run of policy-dp; a network and objective end at their first unfinished run.
    Returns the last run's result."""
    print("| network | objective | T | status | states | seconds | value | lossless bound |")
    print("|---|---|---|---|---|---|---|---|")
    for name, d, objective, horizons in cases:
        for T in horizons:
            t0 = time.perf_counter()
            r = voiopt.solve(lossy(d, T), "policy-dp", objective, time_limit=time_limit)
            s = time.perf_counter() - t0
            value = f"{r.value:.6g}" + ("" if r.status == "optimal" else " (open-loop plan)")
            states = f"{r.solver['states']:,}" + ("" if r.status == "optimal" else "+")
            print(f"| {name} | {objective} | {T} | {r.status} | {states} | {s:.2f} | {value} | "
                  f"{r.solver['lossless']['bound']:.6g} |", flush=True)
            if r.status != "optimal":
                break
    return r


def timed(search) -> tuple[float, float, list]:
    t0 = time.perf_counter()
    value = search.solve()
    rows = search.on_policy()
    return time.perf_counter() - t0, value, rows


def paired(horizons: list[int], plain_limit: float) -> None:
    """Plain against layered on the largest horizon the plain one finishes, per network and objective."""
    print()
    print(f"Paired: the plain expectimax (the reference) against the layered one, search alone (no dp, no "
          f"re-valuation), on the largest T of the list the plain one finishes within {plain_limit:g} s; "
          "identical: the same value (floats equal) and the same action in every on-policy state, in the same order.")
    print()
    print("| network | objective | T | states | plain s | layered s | ratio | identical |")
    print("|---|---|---|---|---|---|---|---|")
    for name, d, objective, _ in cases_of(horizons):
        done = None
        for T in horizons:
            inst = lossy(d, T)
            try:
                plain = Expectimax(inst, objective, stop=Stop(time_limit=plain_limit))
                done = (T, inst, plain, *timed(plain))
            except Stopped:
                break
        if done is None:
            continue
        T, inst, plain, s_plain, v_plain, rows_plain = done
        fast = Layered(inst, objective)
        s_fast, v_fast, rows_fast = timed(fast)
        same = v_fast == v_plain and rows_fast == rows_plain and fast.states == plain.states
        print(f"| {name} | {objective} | {T} | {fast.states:,} | {s_plain:.2f} | {s_fast:.3f} | "
              f"{s_plain / s_fast:.0f} | {'yes' if same else 'NO'} |", flush=True)


def cases_of(horizons: list[int]):
    for name, d in networks():
        for objective in OBJECTIVES:
            yield name, d, objective, horizons


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--time-limit", type=float, default=None, help="seconds per policy-dp run "
                    "(default 60; 900 with --paper-scale)")
    ap.add_argument("--horizons", type=int, nargs="+", default=[6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30])
    ap.add_argument("--plain-limit", type=float, default=60.0, help="seconds the plain expectimax may take a run")
    ap.add_argument("--paper-scale", action="store_true", help="N = 4, T = 30, mean-max-aoi only")
    args = ap.parse_args()
    warm_up()  # the kernels of the layered search and of dp (the lossless bound): the first row's seconds are its work
    dp_warm_up()
    if args.paper_scale:
        d = dict(networks())[PAPER]
        r = frontier([(PAPER, d, "mean-max-aoi", [30])], args.time_limit or 900.0)
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20  # KiB on Linux
        print(f"\nthe policy's table: {r.solver.get('policy_states', 0):,} states it reaches; the lossless dp: "
              f"{r.solver['lossless']['status']}; the process's peak resident memory: {peak:.2f} GiB")
        return 0
    frontier(cases_of(args.horizons), args.time_limit or 60.0)
    paired(args.horizons, args.plain_limit)
    return 0


if __name__ == "__main__":
    import report

    sys.exit(report.run("policy_frontier_paper_scale" if "--paper-scale" in sys.argv else "policy_frontier", main))
