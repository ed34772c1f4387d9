"""How far milp and dp certify two-robot instances as N and T grow, and how close the heuristics get.

Per setting: ``--networks`` networks from the paper's generator with ``--robots`` robots (distinct
random starts, MODEL.md section 10). Each exact method runs with ``--time-limit`` per network
(one process, one thread); the best proven bound over the exact methods is the reference, so
every heuristic gap is certified. dp declines where its product state does not fit (shown as
"declined"). Q-learning runs ``--seeds`` seeds where its joint table fits.

    python benchmarks/fleet_scale.py                                   # default settings, 4 networks each
    python benchmarks/fleet_scale.py --settings n4t10,n6t20 --networks 8 --time-limit 60
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys

import voiopt
from voiopt.errors import VoioptError
from voiopt.objectives import gap

# name -> (N, T, width/height)
SETTINGS = {"n3t10": (3, 10, 3.0), "n4t10": (4, 10, 5.0), "n4t20": (4, 20, 5.0), "n6t20": (6, 20, 5.0),
            "n8t30": (8, 30, 5.0)}
EXACT = ("milp", "dp")
HEURISTICS = ("greedy", "shortest-path", "qlearning")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--settings", default="n3t10,n4t10,n4t20,n6t20,n8t30")
    ap.add_argument("--networks", type=int, default=4)
    ap.add_argument("--robots", type=int, default=2)
    ap.add_argument("--objective", default="mean-min-voi")
    ap.add_argument("--time-limit", type=float, default=60.0, help="per exact solve")
    ap.add_argument("--seeds", type=int, default=2, help="Q-learning seeds 0..K-1 (0: none)")
    ap.add_argument("--episodes", type=int, default=200_000)
    ap.add_argument("--seed", type=int, default=2026)
    args = ap.parse_args(argv)
    print(f"{args.robots} robots, {args.objective}, {args.time_limit:g} s per exact solve, "
          f"Q-learning {args.episodes} episodes x {args.seeds} seeds\n")
    print("| setting | method | certified | median s | median proven gap | worst proven gap |")
    print("|---|---|---|---|---|---|")
    for name in args.settings.split(","):
        n, T, size = SETTINGS[name]
        nets = voiopt.generate_set(args.networks, seed=args.seed, n_sensors=n, horizon=T, width=size, height=size,
                                   robots=args.robots, name=f"{name}-k{args.robots}")
        runs: dict[str, list] = {m: [] for m in (*EXACT, *HEURISTICS)}
        refs = []
        for inst in nets:
            best = None
            for m in EXACT:
                r = _solve(inst, m, args.objective, time_limit=args.time_limit, **({"threads": 1} if m == "milp" else {}))
                runs[m].append(r)
                if r is not None and r.bound is not None:
                    best = r.bound if best is None else min(best, r.bound)
            refs.append(best)
            for m in HEURISTICS:
                seeds = range(args.seeds) if m == "qlearning" else [None]
                for s in seeds:
                    opts = {} if s is None else {"seed": s, "episodes": args.episodes}
                    runs[m].append((_solve(inst, m, args.objective, **opts), best))
        for m in EXACT:
            done = [r for r in runs[m] if r is not None]
            if not done:
                print(f"| {name} (N={n}, T={T}) | {m} | declined | - | - | - |")
                continue
            gaps = [gap(r.value, ref) if r.value is not None and ref is not None else math.inf
                    for r, ref in zip(runs[m], refs, strict=True) if r is not None]
            _row(name, n, T, m, f"{sum(r.status == 'optimal' for r in done)}/{len(done)}",
                 [r.runtime_s for r in done], gaps)
        for m in HEURISTICS:
            done = [(r, ref) for r, ref in runs[m] if r is not None]
            if not done:
                print(f"| {name} (N={n}, T={T}) | {m} | declined | - | - | - |")
                continue
            gaps = [gap(r.value, ref) if r.value is not None and ref is not None else math.inf for r, ref in done]
            _row(name, n, T, m, "-", [r.runtime_s for r, _ in done], gaps)
    return 0


def _solve(inst, method, objective, **opts):
    """A Result, or None where the method declines the fleet (a one-line OptionError, printed)."""
    try:
        return voiopt.solve(inst, method, objective, **opts)
    except VoioptError as e:
        print(f"  {inst.name} {method}: declined: {e}", file=sys.stderr, flush=True)
        return None


def _row(name, n, T, method, certified, times, gaps) -> None:
    finite = [g for g in gaps if math.isfinite(g)]
    med = f"{100 * statistics.median(finite):.2f} %" if finite else "-"
    worst = f"{100 * max(gaps):.2f} %" if finite and len(finite) == len(gaps) else ("-" if not finite else "no plan")
    print(f"| {name} (N={n}, T={T}) | {method} | {certified} | {statistics.median(times):.2f} | {med} | {worst} |",
          flush=True)


if __name__ == "__main__":
    import report

    sys.exit(report.run("fleet_scale", main))
