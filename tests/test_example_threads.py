"""examples/maskable_ppo.py sets torch's threads (one by default: torch's own default, a thread
per core, took 8 min 26 s for 20,000 steps on 2 cores, one thread 30 s), and torch stays out
of `make test` (issue 47, item 8). torch is not installed here, so the example is read, not run."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_the_example_sets_torchs_threads_from_an_option_defaulting_to_one():
    tree = ast.parse((ROOT / "examples" / "maskable_ppo.py").read_text())
    calls = [n for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute)]
    assert any(c.func.attr == "set_num_threads" and ast.unparse(c.args[0]) == "args.threads" for c in calls)
    threads = next(c for c in calls if c.func.attr == "add_argument" and ast.unparse(c.args[0]) == "'--threads'")
    assert {k.arg: ast.unparse(k.value) for k in threads.keywords}["default"] == "1"


def test_make_test_installs_no_torch():
    make = (ROOT / "Makefile").read_text()
    extras = re.search(r'pip install --quiet -e "\.\[([a-z0-9,]+)\]"', make).group(1).split(",")
    assert "sb3" not in extras and "test" in extras
    pyproject = (ROOT / "pyproject.toml").read_text()
    for extra in extras:
        line = re.search(rf"^{extra} = \[(.*)\]", pyproject, re.M).group(1)
        assert "sb3" not in line and "torch" not in line and "stable-baselines" not in line, extra
