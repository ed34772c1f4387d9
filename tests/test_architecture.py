"""The house rules of docs/architecture.md, checked on the source: imports run one way (no
circle, counting imports inside functions), no module is over 500 lines, the objectives'
names are written out in at most two modules, and dependencies point down the layers."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
import typing
from pathlib import Path

import pytest

import voiopt

PACKAGE = Path(__file__).resolve().parent.parent / "voiopt"
MODULES = {
    ".".join(p.relative_to(PACKAGE.parent).with_suffix("").parts).removesuffix(".__init__"): p
    for p in PACKAGE.rglob("*.py")
}
# the layers, bottom up; a module may import its own layer and those below it
LAYERS = [
    ("voiopt.errors", "voiopt._files", "voiopt._grid", "voiopt._checker", "voiopt._places", "voiopt._numba_start", "voiopt._jit", "voiopt._libm", "voiopt._prefault", "voiopt.joint", "voiopt.objectives", "voiopt.instance", "voiopt.fields", "voiopt.physics", "voiopt.lattice",
     "voiopt.plan", "voiopt.simulate", "voiopt.result", "voiopt.generate", "voiopt.stop", "voiopt.progress"),
    ("voiopt.models",),
    ("voiopt.solvers",),
    ("voiopt.env", "voiopt.pz_env", "voiopt.plots", "voiopt.experiments"),
    ("voiopt.cli", "voiopt.cli_bench", "voiopt.cli_validate", "voiopt.cli_output", "voiopt.__main__", "voiopt"),
]


def _layer(module: str) -> int:
    for k, group in enumerate(LAYERS):
        if any(module == g or (g != "voiopt" and module.startswith(g + ".")) for g in group):
            return k
    raise AssertionError(f"{module} is in no layer of tests/test_architecture.py")


def _imports(module: str, path: Path) -> set[str]:
    """The voiopt modules a module imports anywhere in its body (function bodies too)."""
    out = set()
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1] + ([base] if base else []))
            names = [f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES else base for a in node.names]
        else:
            continue
        out |= {n for n in names if n in MODULES and n != module}
    return out


GRAPH = {m: _imports(m, p) for m, p in MODULES.items()}


def test_no_import_circle():
    index, low, stack, on, cycles = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in GRAPH[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in GRAPH:
        if v not in index:
            visit(v)
    assert cycles == []


def test_dependencies_point_down_the_layers():
    upward = [(m, d) for m, deps in GRAPH.items() for d in deps if _layer(d) > _layer(m)]
    assert upward == []


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_module_over_500_lines(module):
    assert len(MODULES[module].read_text().splitlines()) <= 500


def test_objective_names_are_written_out_in_at_most_two_modules():
    names = re.compile(r"[\"'](min-voi|mean-min-voi|max-aoi|mean-max-aoi)[\"']")
    holders = sorted(m for m, p in MODULES.items() if names.search(p.read_text()))
    assert len(holders) <= 2, holders
    assert "voiopt.objectives" in holders


def test_import_voiopt_is_light_and_its_names_are_the_documented_ones():
    """``import voiopt`` imports no numpy (the command catches a Ctrl-C from its first moments,
    voiopt.__main__); every name of ``__all__`` is there when used, and ``voiopt.simulate`` and
    ``voiopt.generate`` stay the functions once the modules of the same names are imported; a
    module of the package is there when used (``voiopt.physics``), as the eager imports made it."""
    code = (
        "import sys, voiopt; light = 'numpy' not in sys.modules\n"
        "from voiopt.simulate import Trajectory\nimport voiopt.generate\n"
        "names = {}\nexec('from voiopt import *', names)\n"
        "print(light, callable(voiopt.simulate), callable(voiopt.generate), sorted(set(voiopt.__all__) - set(names)),"
        " voiopt.simulate.__module__, voiopt.Trajectory is Trajectory, voiopt.physics.__name__)"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.stdout.split() == ["True", "True", "True", "[]", "voiopt.simulate", "True", "voiopt.physics"], proc.stderr
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        voiopt.nope  # noqa: B018
    assert not hasattr(voiopt, "physics.voi") and not hasattr(voiopt, "__wrapped__")
    assert typing.get_type_hints(voiopt.evaluate)["instance"] is voiopt.Instance
