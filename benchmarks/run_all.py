"""``make bench`` and ``make results``: the benchmarks, one after another.

``make bench`` (no options) runs the paper-scale measurements of the quick column of
benchmarks/README.md; each prints its table, and no table in docs/results/ is replaced.

``make results`` (``--results``) runs every benchmark that backs a number in the docs at its full
setting; each writes its table to docs/results/<name>.md (benchmarks/report.py). This takes about
four to five hours on a quiet 2-core machine (docs/reproduce.md); ``--only NAME...`` runs some.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).parent
QUICK = [
    ["qlearning_speed.py"],
    ["exact_scale.py", "--settings", "paper"],
    ["milp_scale.py", "--objectives", "min-voi", "max-aoi", "--threads", "1"],
    ["simulate_speed.py"],
    ["lossy_expectation.py"],
]
#: table name -> the full run that writes it (benchmarks/README.md, column "full")
RESULTS = {
    "qlearning_speed": ["qlearning_speed.py"],
    "qlearning_phases": ["qlearning_phases.py", "--sensors", "8", "--horizon", "40", "--size", "6",
                         "--network-seed", "3", "--episodes", "300000", "--slots", "16777216"],
    "fleet_qlearning_speed": ["fleet_qlearning_speed.py"],  # 20000 episodes: the setting docs/qlearning.md describes
    "reward_reading": ["reward_reading.py"],
    "simulate_speed": ["simulate_speed.py"],
    "exact_scale": ["exact_scale.py", "--settings", "paper,n6,t50,n8"],
    "exact_scale_fields": ["exact_scale.py", "--settings", "walls,f4,f8,f4t60,f12t100", "--networks", "4",
                           "--time-limit", "30"],
    "exact_scale_frontier": ["exact_scale.py", "--settings", "n8,n10,n12,n16,n8t60,n4t100",
                             "--objectives", "mean-min-voi", "--threads", "2"],
    "exact_scale_f30": ["exact_scale.py", "--settings", "f30", "--threads", "2"],
    # one table from four runs: each ingredient switched off in turn (report.combine)
    "exact_scale_ingredients": [["exact_scale.py", "--settings", "paper,n6", "--networks", "8", "--time-limit", "60",
                                 *flags]
                                for flags in ([], ["--no-tdma", "--no-pair"], ["--no-collapse"], ["--no-bounding"])],
    "planner": ["planner.py", "--settings", "paper,n6", "--networks", "10", "--seeds", "3"],
    "fleet_scale": ["fleet_scale.py", "--settings", "n3t10,n4t10,n4t20,n6t20", "--networks", "3",
                    "--time-limit", "30", "--seeds", "2", "--episodes", "200000"],
    "fleet_dp_scale": ["fleet_dp_scale.py"],
    "milp_scale": ["milp_scale.py"],
    "milp_vs_dp": ["milp_vs_dp.py"],
    "lossy_expectation": ["lossy_expectation.py"],
    "voilib_lossy": ["voilib_lossy.py", "--certify"],
    "value_of_adaptivity": ["value_of_adaptivity.py"],
    "qlearning_lossy": ["qlearning_lossy.py"],
    "policy_frontier": ["policy_frontier.py", "--time-limit", "60"],
    "policy_frontier_paper_scale": ["policy_frontier.py", "--paper-scale"],
    "viewer_open": ["viewer_open.py"],
}


def _results(name: str) -> bool:
    """Run the job(s) of one table; several runs are combined into one table."""
    jobs = RESULTS[name]
    if isinstance(jobs[0], str):
        return _run(jobs, {**os.environ, "VOIOPT_RESULTS_NAME": name})
    import report

    with tempfile.TemporaryDirectory() as tmp:
        parts = [Path(tmp) / f"{name}.{i}.md" for i in range(len(jobs))]
        ok = all([_run(job, {**os.environ, "VOIOPT_RESULTS_DIR": tmp, "VOIOPT_RESULTS_NAME": part.stem})
                  for job, part in zip(jobs, parts, strict=True)])
        if ok:
            report.combine(name, parts)
        return ok


def _run(args: list[str], env: dict) -> bool:
    print(f"\n$ python benchmarks/{' '.join(args)}", flush=True)
    return subprocess.call([sys.executable, str(HERE / args[0]), *args[1:]], env=env) == 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--results", action="store_true", help="full runs, each writing docs/results/<name>.md")
    ap.add_argument("--only", nargs="+", choices=sorted(RESULTS), metavar="NAME", help="with --results: these tables")
    args = ap.parse_args(argv)
    failed = 0
    if args.results:
        for name in args.only or RESULTS:
            failed += not _results(name)
    else:
        env = {**os.environ, "VOIOPT_RESULTS_DIR": os.environ.get("VOIOPT_RESULTS_DIR", "-")}
        for job in QUICK:
            failed += not _run(job, env)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
