"""The beam planner's certified gap beside the paper's Q-learning, on the paper's settings.

Per setting: each network is certified by dp (the optimum, or a proven bound at the limit),
then solved by ``beam`` (default widths up to 64) and by the paper's Q-learning (1e6 episodes,
``--seeds`` seeds). Gaps are to dp's proven bound, so they are certified; times are per solve,
one process, one core.

    python benchmarks/planner.py                                  # paper, n6, n8: 10 networks each
    python benchmarks/planner.py --settings paper --networks 20 --seeds 3
"""

from __future__ import annotations

import argparse
import statistics

import voiopt
from voiopt.objectives import gap
from voiopt.solvers.dp import beam
from voiopt.solvers.dp import solver as dp

SETTINGS = {"paper": (4, 30), "n6": (6, 30), "n8": (8, 30)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--settings", default=",".join(SETTINGS))
    ap.add_argument("--networks", type=int, default=10)
    ap.add_argument("--seeds", type=int, default=3, help="Q-learning seeds 0..K-1 (0: no Q-learning)")
    ap.add_argument("--episodes", type=int, default=1_000_000)
    ap.add_argument("--objective", default="mean-min-voi")
    ap.add_argument("--time-limit", type=float, default=60.0, help="dp's limit per network")
    ap.add_argument("--seed", type=int, default=2026)
    args = ap.parse_args(argv)
    dp.warm_up()
    print("| setting | networks certified | method | median gap | mean gap | max gap | within 1 % | median s | max s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in args.settings.split(","):
        n, T = SETTINGS[name]
        nets = voiopt.generate_set(args.networks, seed=args.seed, n_sensors=n, horizon=T, name=name)
        rows = {"beam": [], "qlearning": []}
        certified = 0
        for inst in nets:
            ref = dp.solve(inst, args.objective, time_limit=args.time_limit)
            certified += ref.status == "optimal"
            b = beam.solve(inst, args.objective)
            rows["beam"].append((gap(b.value, ref.bound), b.runtime_s))
            for s in range(args.seeds):
                q = voiopt.solve(inst, "qlearning", args.objective, episodes=args.episodes, seed=s)
                rows["qlearning"].append((gap(q.value, ref.bound), q.runtime_s))
        for method, got in rows.items():
            if not got:
                continue
            gaps, times = [g for g, _ in got], [t for _, t in got]
            runs = "" if method == "beam" else f" ({args.seeds} seeds)"
            print(f"| {name} (N={n}, T={T}) | {certified}/{len(nets)} | {method}{runs} | "
                  f"{100 * statistics.median(gaps):.2f} % | {100 * statistics.mean(gaps):.2f} % | "
                  f"{100 * max(gaps):.2f} % | {sum(g <= 0.01 for g in gaps)}/{len(gaps)} | "
                  f"{statistics.median(times):.2f} | {max(times):.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
