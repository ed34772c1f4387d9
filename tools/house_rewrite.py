"""Rewrite imports and dotted paths from the old flat layout of voiopt to its packages.

    python tools/house_rewrite.py FILE...      rewrite these files in place (idempotent)
    python tools/house_rewrite.py --move       git mv every old module to its new home, then
                                               rewrite every tracked text file

MOVES is the one table of old module -> new module. A file written against the old layout
(a branch that predates the move) is brought up to date by running this on it.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

MOVES = {
    # runtime: what every layer uses
    "voiopt._checker": "voiopt.runtime.checker",
    "voiopt._files": "voiopt.runtime.files",
    "voiopt._jit": "voiopt.runtime.jit",
    "voiopt._numba_start": "voiopt.runtime.numba_start",
    "voiopt._libm": "voiopt.runtime.libm",
    "voiopt.stop": "voiopt.runtime.stop",
    "voiopt.progress": "voiopt.runtime.progress",
    # grid: the lattice and its geometry
    "voiopt._grid": "voiopt.grid.paths",
    "voiopt._places": "voiopt.grid.places",
    "voiopt.joint": "voiopt.grid.joint",
    "voiopt.lattice": "voiopt.grid.lattice",
    # core: the model
    "voiopt.instance": "voiopt.core.instance",
    "voiopt.plan": "voiopt.core.plan",
    "voiopt.simulate": "voiopt.core.simulate",
    "voiopt.result": "voiopt.core.result",
    "voiopt.physics": "voiopt.core.physics",
    # networks
    "voiopt.generate": "voiopt.networks.generate",
    "voiopt.fields": "voiopt.networks.fields",
    # mdp
    "voiopt.models.mdp": "voiopt.mdp.robot",
    "voiopt.models.fleet_mdp": "voiopt.mdp.fleet",
    # milp: the model beside its solver
    "voiopt.models.milp.export": "voiopt.solvers.milp.export",
    "voiopt.models.milp.fleet": "voiopt.solvers.milp.fleet",
    "voiopt.models.milp.formulation": "voiopt.solvers.milp.formulation",
    "voiopt.models.milp.model": "voiopt.solvers.milp.model",
    "voiopt.models.milp.solution": "voiopt.solvers.milp.solution",
    "voiopt.models.milp.solution_file": "voiopt.solvers.milp.solution_file",
    "voiopt.models.milp.cvxpy_model": "voiopt.solvers.milp.cvxpy_model",
    "voiopt.models.milp": "voiopt.solvers.milp",
    "voiopt.models.uploads": "voiopt.solvers.milp.uploads",
    "voiopt.models.pyomo_model": "voiopt.solvers.milp.pyomo",
    "voiopt.solvers.milp": "voiopt.solvers.milp.solver",
    "voiopt.solvers._milp_fleet_start": "voiopt.solvers.milp.fleet_start",
    # dp
    "voiopt.solvers.dp": "voiopt.solvers.dp.solver",
    "voiopt.solvers._dp_core": "voiopt.solvers.labels.kernels",
    "voiopt.solvers._dp_bounds": "voiopt.solvers.labels.bounds",
    "voiopt.solvers._dp_cover": "voiopt.solvers.dp.cover",
    "voiopt.solvers._dp_pattern": "voiopt.solvers.dp.patterns",
    "voiopt.solvers._dp_search": "voiopt.solvers.labels.search",
    "voiopt.solvers._dp_shared": "voiopt.solvers.labels.tables",
    "voiopt.solvers._dp_subsets": "voiopt.solvers.dp.subsets",
    "voiopt.solvers.fleet_dp": "voiopt.solvers.dp.fleet",
    "voiopt.solvers._fleet_dp_core": "voiopt.solvers.labels.fleet_kernels",
    "voiopt.solvers.beam": "voiopt.solvers.dp.beam",
    # baselines
    "voiopt.solvers.baselines": "voiopt.solvers.baselines.heuristics",
    "voiopt.solvers.fleet_baselines": "voiopt.solvers.baselines.fleet",
    # qlearning
    "voiopt.solvers.qlearning._rng": "voiopt.solvers.qlearning.rng",
    "voiopt.solvers.qlearning._qtable": "voiopt.solvers.qlearning.table",
    "voiopt.solvers.qlearning._kernels": "voiopt.solvers.qlearning.kernels",
    "voiopt.solvers.qlearning._fleet": "voiopt.solvers.qlearning.fleet",
    "voiopt._prefault": "voiopt.solvers.qlearning.prefault",
    # experiments, the library, the command line
    "voiopt.plots": "voiopt.experiments.plots",
    "voiopt.experiments.voilib": "voiopt.voilib.library",
    "voiopt.cli_bench": "voiopt.cli.bench",
    "voiopt.cli": "voiopt.cli.main",
}
# names of the package that are functions, not modules: voiopt.simulate(...) stays
FUNCTIONS = {"voiopt.simulate", "voiopt.generate"}
# private names that other modules import, made public with the move
HOMES = {  # private name -> (its public name, the module that defines it)
    "_GOLDEN": ("GOLDEN", "solvers/qlearning/rng.py"), "_S11": ("S11", "solvers/qlearning/rng.py"),
    "_TWO_M53": ("TWO_M53", "solvers/qlearning/rng.py"), "_mix": ("mix", "solvers/qlearning/rng.py"),
    "_find": ("find", "solvers/qlearning/table.py"), "_insert": ("insert", "solvers/qlearning/table.py"),
    "_row": ("row_start", "solvers/qlearning/table.py"), "_slot_reward": ("slot_reward", "solvers/qlearning/kernels.py"),
    "_combine": ("combine", "solvers/dp/kernels.py"), "_join": ("join_path", "runtime/checker.py"),
    "_xy": ("show_xy", "grid/places.py"),
    "_ARG_BITS": ("ARG_BITS", "solvers/qlearning/table.py"), "_ARG_MASK": ("ARG_MASK", "solvers/qlearning/table.py"),
    "_encode": ("encode_key", "solvers/qlearning/table.py"), "_home": ("home_slot", "solvers/qlearning/table.py"),
    "_greedy": ("greedy_action", "solvers/qlearning/table.py"), "_bits": ("bits_for", "mdp/robot.py"),
    "_Triplets": ("Triplets", "solvers/milp/model.py"), "_count": ("count", "cli/arguments.py"),
}
RENAMES = {old: new for old, (new, _) in HOMES.items()}
# names a moved package re-exported -> the module that defines them now (the package no longer does)
PACKAGE_EXPORTS = {
    "voiopt.models.milp": {
        **dict.fromkeys(("EXPORT_FORMATS", "export"), "voiopt.solvers.milp.export"),
        **dict.fromkeys(("LevelTerms", "build", "build_covering", "default_scale", "level_terms"),
                        "voiopt.solvers.milp.formulation"),
        **dict.fromkeys(("Model", "new_highs"), "voiopt.solvers.milp.model"),
        **dict.fromkeys(("SCORE_RTOL", "Structure", "structure"), "voiopt.solvers.milp.uploads"),
    },
}
NEW = set(MOVES.values()) | {"voiopt.runtime", "voiopt.grid", "voiopt.core", "voiopt.networks", "voiopt.mdp",
                             "voiopt.solvers.dp", "voiopt.solvers.milp", "voiopt.solvers.baselines",
                             "voiopt.voilib", "voiopt.cli"}
OLD = set(MOVES)


def _longest(parts: list[str], names: set[str]) -> int:
    for n in range(len(parts), 0, -1):
        if ".".join(parts[:n]) in names:
            return n
    return 0


DOTTED = re.compile(r"\bvoiopt(?:\.\w+)+")


def _dotted(m: re.Match, text: str) -> str:
    chain = m.group(0)
    parts = chain.split(".")
    old, new = _longest(parts, OLD), _longest(parts, NEW)
    if old == 0 or new > old:
        return chain
    head = ".".join(parts[:old])
    exports = PACKAGE_EXPORTS.get(head, {})
    if old < len(parts) and parts[old] in exports:
        return ".".join([exports[parts[old]], *parts[old:]])
    if head in FUNCTIONS and text[m.end():m.end() + 1] == "(" and old == len(parts):
        return chain
    return ".".join([MOVES[head], *parts[old:]])


SLASHED = re.compile(r"\bvoiopt(?:/\w+)+(?:\.py)?")


def _slashed(m: re.Match) -> str:
    path = m.group(0)
    stem, py = (path[:-3], ".py") if path.endswith(".py") else (path, "")
    dotted = stem.replace("/", ".")
    if dotted in OLD and not (dotted in NEW and not py):
        return MOVES[dotted].replace(".", "/") + py
    return path


FROM = re.compile(r"^(?P<indent>[ \t]*)from (?P<mod>voiopt(?:\.\w+)*) import (?P<names>\((?:[^()]|\([^()]*\))*\)|[^\n#]+)",
                  re.M)


def _from(m: re.Match, renamed: dict[str, str]) -> str:
    indent, mod, names = m.group("indent"), m.group("mod"), m.group("names")
    comments = re.findall(r"#[^\n]*", names)
    names = re.sub(r"#[^\n]*", "", names)
    items = [n.strip() for n in names.strip().strip("()").replace("\n", " ").split(",") if n.strip()]
    keep, fresh, lines = [], [], []
    for item in items:
        name, _, alias = item.partition(" as ")
        name, alias = name.strip(), alias.strip()
        full = f"{mod}.{name}"
        if name in PACKAGE_EXPORTS.get(mod, {}):
            lines.append(f"{indent}from {PACKAGE_EXPORTS[mod][name]} import {item}")
        elif full in NEW and full not in OLD and mod not in OLD:  # written for the new layout already
            fresh.append(item)
        elif full in OLD:
            target = MOVES[full]
            parent, leaf = target.rsplit(".", 1)
            local = alias or name
            if local.startswith("_") and not alias:  # a private module name becomes its new public one
                renamed[name] = leaf
                local = leaf
            lines.append(f"{indent}from {parent} import {leaf}" + (f" as {local}" if local != leaf else ""))
        else:
            home = MOVES.get(mod, mod).removeprefix("voiopt.").replace(".", "/") + ".py"
            new_name = RENAMES[name] if name in HOMES and HOMES[name][1] == home else name
            if new_name != name:
                renamed[name] = new_name
                if alias == new_name:
                    alias = ""
            keep.append(new_name + (f" as {alias}" if alias else ""))
    if keep:
        head = DOTTED.sub(lambda d: _dotted(d, ""), mod)
        lines.insert(0, f"{indent}from {head} import {', '.join(keep)}")
    if fresh:
        lines.insert(0, f"{indent}from {mod} import {', '.join(fresh)}")
    if comments and lines:
        lines[0] += "  " + " ".join(comments)
    return "\n".join(lines)


def rewrite(text: str, python: bool) -> str:
    done: list[str] = []  # import statements already rewritten, kept from the dotted pass

    def protect(m: re.Match, renamed: dict[str, str]) -> str:
        done.append(_from(m, renamed))
        return f"\x00{len(done) - 1}\x00"

    if python:
        renamed: dict[str, str] = {}
        text = FROM.sub(lambda m: protect(m, renamed), text)
        for old, new in renamed.items():
            text = re.sub(rf"(?<![\w.]){re.escape(old)}\b", new, text)
    text = DOTTED.sub(lambda m: _dotted(m, m.string), text)
    text = SLASHED.sub(_slashed, text)
    return re.sub("\x00(\\d+)\x00", lambda m: done[int(m.group(1))], text)


def rewrite_file(path: Path) -> bool:
    text = path.read_text()
    new = rewrite(text, path.suffix == ".py")
    if new != text:
        path.write_text(new)
        return True
    return False


def _definitions(root: Path) -> None:
    """Rename the private definitions that HOMES makes public, in their own modules."""
    for old, (name, home) in HOMES.items():
        path = root / "voiopt" / home
        path.write_text(re.sub(rf"(?<![\w.]){re.escape(old)}\b", name, path.read_text()))


def move() -> None:
    root = Path(__file__).resolve().parent.parent
    for old, new in MOVES.items():
        src = root / (old.replace(".", "/") + ".py")
        pkg = root / old.replace(".", "/") / "__init__.py"
        dst = root / (new.replace(".", "/") + ".py")
        if not src.exists() and pkg.exists() and new in NEW and old != new:
            src = pkg
            dst = root / new.replace(".", "/") / "__init__.py"
        if not src.exists():
            continue
        dst.parent.mkdir(parents=True, exist_ok=True)
        staged = dst.parent / ("_staged_" + dst.name)
        subprocess.run(["git", "mv", str(src), str(staged)], check=True, cwd=root)
    for staged in root.glob("voiopt/**/_staged_*.py"):
        subprocess.run(["git", "mv", str(staged), str(staged.with_name(staged.name[len("_staged_"):]))],
                       check=True, cwd=root)
    _definitions(root)
    files = subprocess.run(["git", "ls-files"], capture_output=True, text=True, check=True, cwd=root).stdout.split()
    for f in files:
        p = root / f
        if p.suffix in (".py", ".md", ".toml", ".cfg", ".json") or p.name in ("Makefile",):
            if f.startswith("voiopt/data/") or f == "tools/house_rewrite.py":
                continue
            rewrite_file(p)


if __name__ == "__main__":
    if sys.argv[1:] == ["--move"]:
        move()
    else:
        for f in sys.argv[1:]:
            if rewrite_file(Path(f)):
                print("rewrote", f)
