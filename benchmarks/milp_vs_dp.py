"""milp against dp's proven optimum on small random networks of extreme worths.

    .venv/bin/python benchmarks/milp_vs_dp.py [--seed 1] [--networks 60] [--time-limit 30]

Each network draws N = 2-5 sensors, T = 3-7, a 1-3 x 2 m area, rho in ranges from 1e-6 to 1,
powers of 1e-4, 1 or 1000 W, initial ages up to 300, and two robots in about a third of them:
worths that span dozens of orders of magnitude, where solver tolerances matter most
(docs/milp.md, Numerics). Both objectives of VoI (`mean-min-voi`, `min-voi`) are solved by dp
and by milp. Against dp's optimum (where dp certifies it) each milp result must have a bound
at or above it, a value at or below it, and an `optimal` claim only at it. Prints the
networks, the solves, how many milp certified, and every violation (none expected).
"""

from __future__ import annotations

import argparse
import random
import sys
import time

import voiopt


def networks(seed: int, count: int):
    """(name, instance, generator options) of the random networks (the generator refuses some)."""
    rng = random.Random(seed)
    for k in range(count):
        lo = rng.choice([1e-6, 1e-4, 0.0, 0.3, 0.9])
        hi = max(lo, min(1.0, lo * rng.choice([1, 10, 1e4]) if lo > 0 else rng.random()))
        kw = dict(rho=(lo, hi), power_w=rng.choice([1e-4, 1.0, 1000.0]), initial_aoi=(1, rng.choice([1, 50, 300])))
        if rng.random() < 0.3:
            kw["robots"] = 2
        try:
            inst = voiopt.generate(rng.randint(2, 5), rng.randint(3, 7), width=rng.choice([1.0, 2.0, 3.0]), height=2.0,
                                   seed=k + 1000 * rng.randint(0, 99), **kw)
        except voiopt.errors.VoioptError:
            continue
        yield inst, kw


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--networks", type=int, default=60, help="networks drawn (default 60)")
    ap.add_argument("--time-limit", type=float, default=30.0, help="per solve (default 30 s)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    drawn = solves = certified = 0
    bad = []
    for inst, kw in networks(args.seed, args.networks):
        drawn += 1
        for objective in ("mean-min-voi", "min-voi"):
            d = voiopt.solve(inst, method="dp", objective=objective, time_limit=args.time_limit)
            if d.status != "optimal":
                continue
            m = voiopt.solve(inst, method="milp", objective=objective, time_limit=args.time_limit, threads=1)
            solves += 1
            certified += m.status == "optimal"
            wrong = []
            if m.bound is not None and m.bound < d.value * (1 - 1e-12):
                wrong.append(f"bound {m.bound!r} below the optimum")
            if m.value > d.value * (1 + 1e-12):
                wrong.append(f"value {m.value!r} above the optimum")
            if m.status == "optimal" and abs(m.value - d.value) > 1e-6 * abs(d.value):
                wrong.append(f"'optimal' at {m.value!r}")
            if wrong:
                bad.append(f"{inst.name} {objective} {kw}: {'; '.join(wrong)} (dp's optimum {d.value!r})")
    print(f"{drawn} networks (seed {args.seed}), {solves} milp solves against dp's optimum: "
          f"{certified} certified optimal, {len(bad)} violations ({time.perf_counter() - t0:.0f} s)")
    for line in bad:
        print("VIOLATION", line)
    return 1 if bad else 0


if __name__ == "__main__":
    import report

    sys.exit(report.run("milp_vs_dp", main))
