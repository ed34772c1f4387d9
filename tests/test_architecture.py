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
ARCHITECTURE = PACKAGE.parent / "docs" / "architecture.md"


def _listed() -> list[str]:
    """The modules of docs/architecture.md's layer list, top down."""
    text = ARCHITECTURE.read_text()
    block = text[text.index("<!-- layers -->"):text.index("<!-- /layers -->")]
    return [line.split()[0] for line in block.splitlines() if line.startswith("voiopt")]


LISTED = _listed()


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


def test_every_module_is_listed_once_in_the_architecture_page():
    assert sorted(LISTED) == sorted(MODULES), (set(MODULES) - set(LISTED), set(LISTED) - set(MODULES))
    assert len(LISTED) == len(set(LISTED))


def test_every_import_points_down_the_list():
    rank = {m: k for k, m in enumerate(LISTED)}
    upward = sorted((m, d) for m, deps in GRAPH.items() for d in deps if m in rank and d in rank and rank[d] <= rank[m])
    assert upward == []


def test_the_root_holds_only_the_public_face():
    root = sorted(p.stem for p in PACKAGE.glob("*.py"))
    assert root == ["__init__", "__main__", "env", "errors", "objectives", "pz_env"]


def test_no_private_module_and_no_private_name_crosses_a_module():
    private_modules = [m for m, p in MODULES.items() if p.name.startswith("_") and p.name not in ("__init__.py", "__main__.py")]
    assert private_modules == []
    crossing = []
    for module, path in MODULES.items():
        tree = ast.parse(path.read_text())
        aliases = set()  # names bound to voiopt modules in this module
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("voiopt"):
                for a in node.names:
                    if a.name.startswith("_") and not a.name.startswith("__"):
                        crossing.append((module, f"{node.module}.{a.name}"))
                    if f"{node.module}.{a.name}" in MODULES:
                        aliases.add(a.asname or a.name)
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in aliases
                    and node.attr.startswith("_") and not node.attr.startswith("__")):
                crossing.append((module, f"{node.value.id}.{node.attr}"))
    assert crossing == [], crossing


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
    voiopt.__main__); every name of ``__all__`` is there when used; ``voiopt.simulate`` and
    ``voiopt.generate`` are the functions; a sub-package is there when used (``voiopt.core``)."""
    code = (
        "import sys, voiopt; light = 'numpy' not in sys.modules\n"
        "from voiopt.core.simulate import Trajectory\n"
        "names = {}\nexec('from voiopt import *', names)\n"
        "print(light, callable(voiopt.simulate), callable(voiopt.generate), sorted(set(voiopt.__all__) - set(names)),"
        " voiopt.simulate.__module__, voiopt.Trajectory is Trajectory, voiopt.core.__name__)"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.stdout.split() == ["True", "True", "True", "[]", "voiopt.core.simulate", "True", "voiopt.core"], proc.stderr
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        voiopt.nope  # noqa: B018
    assert not hasattr(voiopt, "physics.voi") and not hasattr(voiopt, "__wrapped__")
    assert typing.get_type_hints(voiopt.evaluate)["instance"] is voiopt.Instance
