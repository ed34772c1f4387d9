"""Two trees of voiopt on all of VoI-Lib: every instance and objective solved by the
deterministic methods (greedy, shortest-path, and beam for one robot at its pre-budget widths,
max_width=64), each result compared field by field (status, value, bound, gap, plan, metrics).
A refactor must leave every one identical.

    python benchmarks/voilib_equivalence.py --before ../old --after . [--out DIR]

Each tree solves in its own process (``PYTHONPATH=TREE``); the results are kept in DIR/before
and DIR/after, so that ``voiopt bench score DIR/after/*.json`` can score them too.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

SOLVE = r"""
import inspect, pathlib, sys
import voiopt
try:
    from voiopt.voilib import library as lib
except ImportError:  # a tree from before the package layout
    from voiopt.experiments import voilib as lib
out = pathlib.Path(sys.argv[1]); out.mkdir(parents=True, exist_ok=True)
for name, inst in sorted(lib.instances().items()):
    for objective in ("min-voi", "mean-min-voi", "max-aoi", "mean-max-aoi"):
        methods = ["greedy", "shortest-path"] + ([] if inst.n_robots > 1 else ["beam"])
        for method in methods:
            r = voiopt.solve(inst, method, objective, **({"max_width": 64} if method == "beam" else {}))
            r.runtime_s, r.solver = 0.0, {}
            r.save(out / f"{name}__{objective}__{method}.json")
"""
FIELDS = ("status", "value", "bound", "gap", "plan", "metrics")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--before", type=Path, required=True)
    p.add_argument("--after", type=Path, default=Path("."))
    p.add_argument("--out", type=Path, default=None)
    a = p.parse_args()
    out = a.out or Path(tempfile.mkdtemp(prefix="voilib-equivalence-"))
    for side, tree in (("before", a.before), ("after", a.after)):
        env = {**os.environ, "PYTHONPATH": str(tree.resolve())}
        subprocess.run([sys.executable, "-c", SOLVE, str(out / side)], env=env, check=True, cwd=tree)
    before = sorted((out / "before").glob("*.json"))
    differ = []
    for f in before:
        x, y = json.loads(f.read_text()), json.loads((out / "after" / f.name).read_text())
        if any(x[k] != y[k] for k in FIELDS):
            differ.append(f.name)
    print(f"| results | identical | different |\n|---:|---:|---:|\n| {len(before)} | {len(before) - len(differ)} | "
          f"{len(differ)} |")
    for name in differ:
        print(f"differs: {name}")
    print(f"results kept in {out}")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
