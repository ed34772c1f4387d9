"""Two trees of voiopt, timed in one run: each benchmark of ``make bench`` is run from each
tree in turn (``PYTHONPATH=TREE python TREE/benchmarks/NAME``), alternating so that both
see the same machine, after one untimed warm-up each (numba's caches). Reports each tree's
median wall time and the ratio after/before: a move or refactor should leave it within noise.

    python benchmarks/paired.py --before ../old --after . [--rounds 3] [NAME ...]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

DEFAULT = ["simulate_speed.py", "qlearning_phases.py", "lossy_expectation.py"]


def _time(tree: Path, name: str, args: list[str]) -> float:
    env = {**os.environ, "PYTHONPATH": str(tree), "VOIOPT_RESULTS_DIR": "-"}
    start = time.perf_counter()
    subprocess.run([sys.executable, str(tree / "benchmarks" / name), *args], env=env, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tree)
    return time.perf_counter() - start


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--before", type=Path, required=True)
    p.add_argument("--after", type=Path, default=Path("."))
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("names", nargs="*", default=DEFAULT)
    a = p.parse_args()
    trees = {"before": a.before.resolve(), "after": a.after.resolve()}
    print("| benchmark | before median s | after median s | after/before | rounds |\n|---|---:|---:|---:|---:|")
    for name in a.names:
        if not all((t / "benchmarks" / name).exists() for t in trees.values()):
            print(f"| {name} | - | - | not in both trees | - |")
            continue
        for t in trees.values():
            _time(t, name, [])  # warm-up: numba compiles or loads its cache
        times = {k: [] for k in trees}
        for _ in range(a.rounds):
            for k, t in trees.items():
                times[k].append(_time(t, name, []))
        b, f = statistics.median(times["before"]), statistics.median(times["after"])
        print(f"| {name} | {b:.2f} | {f:.2f} | {f / b:.3f} | {a.rounds} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
