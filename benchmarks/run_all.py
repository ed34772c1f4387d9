"""``make bench``: the paper-scale measurements of every benchmark, one after another.

Each benchmark prints its own table. The full runs (larger settings, all 40 networks of every
objective) take an hour or more; their commands are in benchmarks/README.md.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).parent
QUICK = [
    ["qlearning_speed.py"],
    ["exact_scale.py", "--settings", "paper"],
    ["milp_scale.py", "--objectives", "min-voi", "max-aoi", "--threads", "1"],
    ["simulate_speed.py"],
    ["lossy_expectation.py"],
]


def main() -> int:
    failed = 0
    for args in QUICK:
        print(f"\n$ python benchmarks/{' '.join(args)}", flush=True)
        failed += subprocess.call([sys.executable, str(HERE / args[0]), *args[1:]]) != 0
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
