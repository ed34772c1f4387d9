"""How far ``dp`` certifies two-robot instances (MODEL.md section 10, docs/dp.md "Several robots").

Per setting and objective: networks certified optimal, median and maximum wall time, median
labels, peak label memory, and the median proven gap of those not certified. Robot 0 starts
where the generator put the entity, robot 1 at a random other lattice point (seeded). One
process, networks one after another.

    f3     N = 3, T = 10, 3 x 3 points
    f4     N = 4, T = 15, 4 x 4 points
    paper  N = 4, T = 30, 6 x 6 points (the paper's 5 x 5 m square)
    n6     N = 6, T = 30, 6 x 6 points
    dock   N = 4, T = 30, 6 x 6 points, each robot back at its start, at most 20 moves each

Usage:
    python benchmarks/fleet_dp_scale.py                                  # everything (about 20 min)
    python benchmarks/fleet_dp_scale.py --settings f3,f4 --networks 3
"""

from __future__ import annotations

import random
import resource
import statistics
import sys
import time

from exact_scale import _print_row, parser

import voiopt
from voiopt.core.instance import from_dict
from voiopt.solvers.dp import fleet as fleet_dp

SETTINGS = {
    "f3": dict(n_sensors=3, horizon=10, size=2.0, networks=5, time_limit=60.0),
    "f4": dict(n_sensors=4, horizon=15, size=3.0, networks=5, time_limit=60.0),
    "paper": dict(n_sensors=4, horizon=30, size=5.0, networks=5, time_limit=60.0),
    "n6": dict(n_sensors=6, horizon=30, size=5.0, networks=3, time_limit=60.0),
    "dock": dict(n_sensors=4, horizon=30, size=5.0, networks=5, time_limit=60.0, dock=True, max_moves=20),
}


def networks(name: str, count: int, seed: int) -> list[voiopt.Instance]:
    s = SETTINGS[name]
    rng = random.Random(seed)
    out = []
    for inst in voiopt.generate_set(count, seed=seed, n_sensors=s["n_sensors"], horizon=s["horizon"], width=s["size"],
                                    height=s["size"], rho=(0.0, 1.0), power_w=1.0, name=f"{name}-seed{seed}"):
        d = inst.to_dict()
        a = d.pop("start")
        side = int(s["size"]) + 1
        b = rng.choice([[x, y] for x in range(side) for y in range(side) if [x, y] != a])
        d["robots"] = [{"start": a}, {"start": b}]
        if s.get("dock"):
            for r in d["robots"]:
                r["end"], r["max_moves"] = r["start"], s["max_moves"]
        out.append(from_dict(d))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__, SETTINGS)
    ap.add_argument("--verbose", "-v", action="store_true", help="one line per network")
    args = ap.parse_args(argv)
    settings = [s for s in args.settings.split(",") if s]
    objectives = [o for o in args.objectives.split(",") if o]
    for s in settings:
        if s not in SETTINGS:
            ap.error(f"--settings: unknown setting {s!r} (choose from {', '.join(SETTINGS)})")
    t = time.perf_counter()
    fleet_dp.warm_up()
    print(f"# dp for two robots; warm-up (numba compile or cache load) {time.perf_counter() - t:.1f} s", flush=True)
    rows = []
    for name in settings:
        spec = SETTINGS[name]
        limit = args.time_limit if args.time_limit is not None else spec["time_limit"]
        insts = networks(name, args.networks or spec["networks"], args.seed)
        for objective in objectives:
            results = []
            for inst in insts:
                r = voiopt.solve(inst, method="dp", objective=objective, time_limit=limit)
                results.append(r)
                if args.verbose:
                    print(f"  {inst.name} {objective}: {r.status} {r.runtime_s:.3f} s value {r.value:.6g} "
                          f"gap {r.gap} labels {r.solver['labels']:,}", flush=True)
            open_gaps = [r.gap for r in results if r.status != "optimal" and r.gap is not None]
            times = [r.runtime_s for r in results]
            rows.append(dict(
                setting=f"{name} (N={spec['n_sensors']}, T={spec['horizon']}, {spec['size']:g}x{spec['size']:g})",
                objective=objective, certified=f"{sum(r.status == 'optimal' for r in results)}/{len(results)}",
                median=statistics.median(times), max=max(times),
                peak_mb=max(r.solver["peak_label_bytes"] for r in results) / 1e6,
                labels=statistics.median(r.solver["labels"] for r in results),
                gap=statistics.median(open_gaps) if open_gaps else None,
                gap_all=statistics.median(r.gap if r.gap is not None else float("inf") for r in results),
                worst=max(r.gap if r.gap is not None else float("inf") for r in results), limit=limit,
            ))
            _print_row(rows[-1], header=len(rows) == 1)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\nprocess peak RSS {rss:.0f} MB (numba, numpy and the labels together)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
