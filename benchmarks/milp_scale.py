"""How far the exact MILP gets at the paper's scale (issue 3): Fig. 7 networks, N = 4, T = 30.

For each objective: how many networks were certified optimal within the time limit, the
median and maximum solve time, and the median proven gap of the networks not certified.

    .venv/bin/python benchmarks/milp_scale.py                      # 40 networks, 60 s each
    .venv/bin/python benchmarks/milp_scale.py --networks 10 --time-limit 20 --objectives min-voi
    .venv/bin/python benchmarks/milp_scale.py --robots 2 --horizon 20 --networks 5   # fleets (issue 14)

With ``--robots K`` each network gets K - 1 more robots (MODEL.md section 10), robot j at the
j-th lattice point of the sequence "mirror of the start, then the corners" that is not taken.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

import voiopt
from voiopt.core.instance import from_dict
from voiopt.objectives import OBJECTIVES


def with_robots(inst: voiopt.Instance, k: int) -> voiopt.Instance:
    """The network with k robots: its own start first, then distinct far points."""
    if k == 1:
        return inst
    w, h = inst.width, inst.height
    x, y = inst.start
    spots = [(w - x, h - y), (0.0, 0.0), (w, h), (0.0, h), (w, 0.0)]
    taken = [(x, y)]
    for p in spots:
        if len(taken) < k and p not in taken:
            taken.append(p)
    d = inst.to_dict()
    del d["start"]
    d["robots"] = [{"start": list(p)} for p in taken]
    return from_dict(d)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--networks", type=int, default=40)
    ap.add_argument("--time-limit", type=float, default=60.0, metavar="S")
    ap.add_argument("--objectives", nargs="+", default=list(OBJECTIVES), choices=list(OBJECTIVES))
    ap.add_argument("--sensors", type=int, default=4)
    ap.add_argument("--horizon", type=int, default=30)
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--robots", type=int, default=1, choices=range(1, 6), metavar="K")
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--json", default=None, metavar="FILE", help="also write every result here")
    args = ap.parse_args(argv)

    networks = voiopt.generate_set(
        args.networks, seed=args.seed, n_sensors=args.sensors, horizon=args.horizon, name="fig7"
    )
    networks = [with_robots(inst, args.robots) for inst in networks]
    print(
        f"MILP (HiGHS) on {args.networks} networks, K = {args.robots}, N = {args.sensors}, T = {args.horizon}, 5 x 5, "
        f"rho ~ U(0, 1), P = 1 W; time limit {args.time_limit:g} s each",
        flush=True,
    )
    header = f"{'objective':<14} {'certified':>10} {'median s':>9} {'max s':>8} {'median gap (rest)':>18}"
    rows, raw = [], []
    for objective in args.objectives:
        times, gaps, certified = [], [], 0
        for inst in networks:
            opts = {"time_limit": args.time_limit}
            if args.threads is not None:
                opts["threads"] = args.threads
            t = time.perf_counter()
            r = voiopt.solve(inst, method="milp", objective=objective, **opts)
            times.append(time.perf_counter() - t)
            if r.status == "optimal":
                certified += 1
            elif r.gap is not None:
                gaps.append(r.gap)
            raw.append(r.to_dict())
            print(f"  {objective} {inst.name}: {r.status} value {r.value:.6g} bound {r.bound!s:.10} "
                  f"gap {r.gap if r.gap is not None else float('nan'):.3g} in {times[-1]:.2f} s",
                  file=sys.stderr, flush=True)
        gap = f"{100 * statistics.median(gaps):.1f} %" if gaps else "-"
        rows.append(
            f"{objective:<14} {certified:>5} / {len(networks):<3} {statistics.median(times):>9.2f} "
            f"{max(times):>8.2f} {gap:>18}"
        )
        print(rows[-1], flush=True)
    print()
    print(header)
    print("\n".join(rows))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(raw, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
