"""Q-learning (the paper's Algorithm 1, learning from sampled outcomes) at the paper's scale
under lossy links: a paper-scale network (N = 4, T = 30, generated with seed 3) with bernoulli
links of success 0.7. For each averaged objective (``qlearning`` for mean-min-voi,
``aoi-qlearning`` for mean-max-aoi), each episode count and each seed: the greedy policy's
value with how it was evaluated (exact forward enumeration, or Monte Carlo with its 95 % CI
and sample count), how many of its decisions fell back (states the table never visited), the
seconds, and its gap to the tightest proven bound: the optimal policy's exact value where
``policy-dp`` finishes within ``--policy-time-limit``, else the lossless optimum (dp without
links). Writes docs/results/qlearning_lossy.md.

    python benchmarks/qlearning_lossy.py [--episodes 100000 1000000] [--seeds 3]
                                          [--policy-time-limit 300] [--horizon 30]
"""

from __future__ import annotations

import argparse
import sys

import voiopt
from voiopt.core.instance import from_dict
from voiopt.networks.generate import generate

LINKS = {"model": "bernoulli", "success": 0.7}
METHODS = {"mean-min-voi": "qlearning", "mean-max-aoi": "aoi-qlearning"}


def _gap(value: float, bound: float, maximise: bool) -> float:
    return 100.0 * ((bound - value) / abs(bound) if maximise else (value - bound) / abs(bound))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--episodes", type=float, nargs="+", default=[1e5, 1e6])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--horizon", type=int, default=30)
    ap.add_argument("--policy-time-limit", type=float, default=300.0,
                    help="seconds for policy-dp's exact optimal policy (default 300)")
    args = ap.parse_args()
    inst = from_dict(generate(4, 30, seed=3, name="paper-seed3").to_dict() | {"horizon": args.horizon, "links": LINKS})
    print(f"Network: `generate(4, 30, seed=3)` (the same as `voiopt generate --seed 3`), T = {args.horizon}, "
          "bernoulli links of success 0.7. Gap: to the optimal policy's exact value where policy-dp finishes, else "
          "to the lossless optimum (bound kind in the row).")
    print()
    print("| objective | method | episodes | seed | value | evaluation | decisions from table / fallback | seconds | "
          "bound | bound kind | gap to bound |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for objective, method in METHODS.items():
        print(f"{objective}: policy-dp ...", file=sys.stderr, flush=True)
        best = voiopt.solve(inst, "policy-dp", objective, time_limit=args.policy_time_limit)
        exact = best.status == "optimal"
        bound = best.value if exact else best.bound
        kind = "exact (policy-dp)" if exact else f"lossless (policy-dp: {best.status})"
        maximise = voiopt.objectives.get(objective).maximise
        print(f"| {objective} | policy-dp | | | {best.value:.6g} | {best.evaluation} | {best.solver.get('policy_states', '')} "
              f"states | {best.runtime_s:.1f} | {bound:.6g} | {kind} | {_gap(best.value, bound, maximise):.2f} % |",
              flush=True)
        for episodes in args.episodes:
            for seed in range(args.seeds):
                print(f"{objective}: {method} {episodes:g} episodes, seed {seed} ...", file=sys.stderr, flush=True)
                r = voiopt.solve(inst, method, objective, episodes=int(episodes), seed=seed)
                how = r.evaluation if r.evaluation == "exact" else \
                    f"{r.evaluation} (95 % CI {r.value_ci[0]:.6g}-{r.value_ci[1]:.6g}, {r.samples} samples)"
                d = r.solver["decisions"]
                print(f"| {objective} | {method} | {episodes:g} | {seed} | {r.value:.6g} | {how} | "
                      f"{d['from_table']} / {d['fallback']} | {r.runtime_s:.2f} | {bound:.6g} | {kind} | "
                      f"{_gap(r.value, bound, maximise):.2f} % |", flush=True)


if __name__ == "__main__":
    import report

    sys.exit(report.run("qlearning_lossy", main))
