"""How far the exact label-setting programme (method ``dp``) certifies optimality.

Per setting and objective it prints how many networks were certified optimal, the median and
maximum wall time, the peak label memory, and the median proven gap of those not certified.
One process, networks solved one after another, on one core unless ``--threads K``. Targets (issue 5):

    paper  N = 4, T = 30, 5 x 5, 40 networks          all certified, median < 0.2 s, max < 2 s
    n6     N = 6, T = 30, 5 x 5, 20 networks, 60 s    >= 18 certified
    t50    N = 4, T = 50, 10 x 10, 20 networks, 60 s  >= 18 certified
    n8     N = 8, T = 30, 5 x 5, 20 networks, 60 s    median proven gap < 1 %

The frontier (issue 15; targets for mean-min-voi, 60 s per network, one process per network on
this 2-core machine, so ``--threads 2``; docs/dp.md "The frontier"):

    n10    N = 10, T = 30, 5 x 5, 8 networks
    n12    N = 12, T = 30, 5 x 5, 6 networks             >= 5 certified
    n16    N = 16, T = 30, 5 x 5, 6 networks             median proven gap < 1 %
    n8t60  N = 8, T = 60, 10 x 10, 8 networks            all certified
    n4t100 N = 4, T = 100, 10 x 10, 8 networks
    f30    the factory preset with N = 30, T = 100, 300 s   proven gap <= 25 % (aim: 5 %)

With the field rules of MODEL.md section 9 (issue 13; no targets, a measurement):

    walls    N = 4, T = 30, 5 x 5, 20 % blocked, back to the start, at most 20 moves
    f4, f8   the factory preset (20 x 20 m, racks, dock at (0, 0)) with N = 4 and 8, T = 30
    f4t60    the factory preset, N = 4, T = 60
    f12t100  the factory preset, N = 12, T = 100 (a budget of 80 % of the slots throughout)

Usage:
    python benchmarks/exact_scale.py                       # everything (long: run it in the background)
    python benchmarks/exact_scale.py --settings paper      # one part
    python benchmarks/exact_scale.py --settings n6,n8 --networks 5 --objectives mean-min-voi
    python benchmarks/exact_scale.py --settings paper --no-collapse   # measure one ingredient
    python benchmarks/exact_scale.py --settings walls,f4,f8,f4t60,f12t100 --networks 4 --time-limit 30
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import sys
import time

import voiopt
from voiopt.errors import OptionError
from voiopt.objectives import OBJECTIVES
from voiopt.solvers.base import check_threads
from voiopt.solvers.dp import solver as dp

SETTINGS = {
    "paper": dict(n_sensors=4, horizon=30, size=5.0, networks=40, time_limit=None),
    "n6": dict(n_sensors=6, horizon=30, size=5.0, networks=20, time_limit=60.0),
    "t50": dict(n_sensors=4, horizon=50, size=10.0, networks=20, time_limit=60.0),
    "n8": dict(n_sensors=8, horizon=30, size=5.0, networks=20, time_limit=60.0),
    # the field model (MODEL.md section 9): the paper's square with obstacles, a dock and a budget,
    "walls": dict(n_sensors=4, horizon=30, size=5.0, networks=20, time_limit=60.0, blocked_fraction=0.2,
                  end="start", max_moves=20),
    # and the factory preset (20 x 20 m, racks, the dock at a corner, a budget of 80 % of the slots)
    "f4": dict(n_sensors=4, horizon=30, size=20.0, networks=8, time_limit=60.0, preset="factory"),
    "f8": dict(n_sensors=8, horizon=30, size=20.0, networks=8, time_limit=60.0, preset="factory"),
    "f4t60": dict(n_sensors=4, horizon=60, size=20.0, networks=8, time_limit=60.0, preset="factory"),
    "f12t100": dict(n_sensors=12, horizon=100, size=20.0, networks=8, time_limit=60.0, preset="factory"),
    # the frontier (issue 15): larger paper-style networks, and the factory floor with 30 sensors
    "n10": dict(n_sensors=10, horizon=30, size=5.0, networks=8, time_limit=60.0),
    "n12": dict(n_sensors=12, horizon=30, size=5.0, networks=6, time_limit=60.0),
    "n16": dict(n_sensors=16, horizon=30, size=5.0, networks=6, time_limit=60.0),
    "n8t60": dict(n_sensors=8, horizon=60, size=10.0, networks=8, time_limit=60.0),
    "n4t100": dict(n_sensors=4, horizon=100, size=10.0, networks=8, time_limit=60.0),
    "f30": dict(n_sensors=30, horizon=100, size=20.0, networks=4, time_limit=300.0, preset="factory"),
}


def networks(name: str, count: int, seed: int) -> list[voiopt.Instance]:
    s = SETTINGS[name]
    if s.get("preset") == "factory":
        return voiopt.generate_set(count, seed=seed, preset="factory", n_sensors=s["n_sensors"], horizon=s["horizon"],
                                   max_moves=int(0.8 * (s["horizon"] - 1)), name=f"{name}-seed{seed}")
    fields = {k: s[k] for k in ("blocked_fraction", "end", "max_moves") if k in s}
    return voiopt.generate_set(count, seed=seed, n_sensors=s["n_sensors"], horizon=s["horizon"],
                               width=s["size"], height=s["size"], rho=(0.0, 1.0), power_w=1.0,
                               name=f"{name}-seed{seed}", **fields)


def parser(doc: str, settings: dict) -> argparse.ArgumentParser:
    """The options every scale benchmark shares: settings, networks, objectives, seed, time limit."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("--settings", default=",".join(settings), help=f"comma list of {', '.join(settings)}")
    ap.add_argument("--networks", type=int, help="networks per setting (default: the setting's count)")
    ap.add_argument("--objectives", default=",".join(OBJECTIVES))
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--time-limit", type=float, help="override the settings' time limits (seconds)")
    return ap


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__, SETTINGS)
    ap.add_argument("--beam", type=int, default=dp.DEFAULT_BEAM, help="beam width of the incumbent pass (0: off)")
    ap.add_argument("--no-greedy", action="store_true", help="no greedy incumbent")
    ap.add_argument("--no-collapse", action="store_true", help="never collapse a sensor")
    ap.add_argument("--no-bounding", action="store_true", help="no bound pruning (dominance only)")
    ap.add_argument("--no-tdma", action="store_true", help="per-sensor bound only, without the distinct-ages step")
    ap.add_argument("--no-pair", action="store_true", help="no pairwise travel bound")
    ap.add_argument("--no-tour", action="store_true", help="no tour bound")
    ap.add_argument("--no-subsets", action="store_true", help="no subset relaxation")
    ap.add_argument("--no-patterns", action="store_true", help="no pattern database in the bounded pass")
    ap.add_argument("--no-fast-pass", action="store_true", help="compute the incumbents before the first pass")
    ap.add_argument("--threads", type=int, default=1, help="dp's threads (chunks of a slot expanded at once)")
    ap.add_argument("--verbose", "-v", action="store_true", help="one line per network")
    ap.add_argument("--json", help="also write every run to this JSON file")
    args = ap.parse_args(argv)
    options = dict(beam=args.beam, greedy=not args.no_greedy, collapse=not args.no_collapse,
                   bounding=not args.no_bounding, tdma=not args.no_tdma,
                   pair_bound=not args.no_pair, tour_bound=not args.no_tour,
                   subsets=not args.no_subsets, patterns=not args.no_patterns, threads=args.threads)
    if args.no_fast_pass:
        options["fast_budget"] = 0
    settings = [s for s in args.settings.split(",") if s]
    objectives = [o for o in args.objectives.split(",") if o]
    for s in settings:
        if s not in SETTINGS:
            ap.error(f"--settings: unknown setting {s!r} (choose from {', '.join(SETTINGS)})")
    for o in objectives:
        if o not in OBJECTIVES:
            ap.error(f"--objectives: unknown objective {o!r}")
    try:
        check_threads(args.threads)
    except OptionError as e:
        ap.error(str(e))

    t = time.perf_counter()
    for o in OBJECTIVES:  # compile (or load the numba cache) before anything is timed
        dp.solve(voiopt.generate(2, 4, width=2, height=2, seed=0), o)
    print(f"# dp options {options}; warm-up (numba compile or cache load) {time.perf_counter() - t:.1f} s",
          flush=True)

    rows, runs = [], []
    for name in settings:
        spec = SETTINGS[name]
        count = args.networks or spec["networks"]
        limit = args.time_limit if args.time_limit is not None else spec["time_limit"]
        insts = networks(name, count, args.seed)
        for objective in objectives:
            results = []
            for inst in insts:
                r = dp.solve(inst, objective, time_limit=limit, **options)
                results.append(r)
                runs.append(dict(setting=name, network=inst.name, objective=objective, status=r.status,
                                 value=r.value, bound=r.bound, gap=r.gap, runtime_s=r.runtime_s,
                                 labels=r.solver["labels"], peak_label_bytes=r.solver["peak_label_bytes"]))
                if args.verbose:
                    print(f"  {name} {inst.name} {objective}: {r.status} {r.runtime_s:.3f} s value {r.value:.6g} "
                          f"gap {r.gap:.3g} labels {r.solver['labels']:,}", flush=True)
            times = [r.runtime_s for r in results]
            open_gaps = [r.gap for r in results if r.status != "optimal"]
            rows.append(dict(
                setting=f"{name} (N={spec['n_sensors']}, T={spec['horizon']}, {spec['size']:g}x{spec['size']:g})",
                objective=objective,
                certified=f"{sum(r.status == 'optimal' for r in results)}/{len(results)}",
                median=statistics.median(times), max=max(times),
                peak_mb=max(r.solver["peak_label_bytes"] for r in results) / 1e6,
                labels=statistics.median(r.solver["labels"] for r in results),
                gap=statistics.median(open_gaps) if open_gaps else None,
                gap_all=statistics.median(r.gap for r in results),
                worst=max(r.gap for r in results),
                limit=limit,
            ))
            _print_row(rows[-1], header=len(rows) == 1)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\nprocess peak RSS {rss:.0f} MB (numba, numpy and the labels together)")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(dict(options=options, seed=args.seed, rows=rows, runs=runs), f, indent=1)
    return 0


def _print_row(row: dict, header: bool) -> None:
    if header:
        print("| setting | objective | certified | median s | max s | median labels | peak label MB "
              "| median gap of uncertified | median gap of all | worst gap | limit s |")
        print("|---|---|---|---|---|---|---|---|---|---|---|")
    gap = "-" if row["gap"] is None else f"{100 * row['gap']:.3g} %"
    gap_all = f"{100 * row['gap_all']:.3g} %"
    limit = "-" if row["limit"] is None else f"{row['limit']:g}"
    print(f"| {row['setting']} | {row['objective']} | {row['certified']} | {row['median']:.3f} | {row['max']:.3f} | "
          f"{row['labels']:,.0f} | {row['peak_mb']:.1f} | {gap} | {gap_all} | {100 * row['worst']:.3g} % | {limit} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
