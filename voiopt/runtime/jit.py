"""How voiopt's kernels are compiled: numba's ``njit``, cached on disk under a stamp that
covers every kernel module of the package.

numba keys a cached kernel by the one file that defines it. A kernel that calls or inlines
kernels of another module (dp's ``expand`` the bounds of ``_dp_bounds``, the Q-learning
kernels the probes of ``_qtable`` and the random stream of ``_rng``) would keep its old
machine code when only that other module changed, for instance after a ``git pull``, and give
the old numbers without a word. So voiopt's kernel modules take ``njit`` from here: importing
this module puts, ahead of numba's own cache locators, variants for the files of this package
whose stamp is numba's and the digest of all of ``KERNEL_MODULES`` and of the package's
modules they import (``stamped``: a kernel freezes the constants and functions it reads from
them). Editing any of them recompiles every kernel once (and so does editing this module, whose ``prefetch`` intrinsic is
compiled into kernels). Functions outside the package are cached as numba does by itself
(and a user who sets ``NUMBA_CACHE_LOCATOR_CLASSES`` chooses the locators, this included).
"""

from __future__ import annotations

import ast
import hashlib
from pathlib import Path

import numba
from llvmlite import ir
from numba.core import caching, cgutils, types
from numba.extending import intrinsic

njit = numba.njit
USING_SVML = numba.config.USING_SVML  # numba vectorises math through Intel's SVML (voiopt.runtime.libm)

ROOT = Path(__file__).resolve().parent.parent  # the package
KERNEL_MODULES = (  # every module of the package that defines kernels (tests/test_jit.py keeps this complete)
    "runtime/libm.py",
    "grid/joint.py",
    "solvers/labels/bounds.py",
    "solvers/labels/kernels.py",
    "solvers/dp/patterns.py",
    "solvers/labels/fleet_kernels.py",
    "solvers/qlearning/fleet.py",
    "solvers/qlearning/kernels.py",
    "solvers/qlearning/table.py",
    "solvers/qlearning/rng.py",
    "solvers/policy/kernels.py",
)
_digests: dict[tuple, str] = {}


def digest() -> str:
    """SHA-256 of the stamped modules' names and contents (once per process and set of files)."""
    key = (ROOT, KERNEL_MODULES)
    if key not in _digests:
        h = hashlib.sha256(Path(__file__).read_bytes())  # this module's intrinsics are compiled into kernels
        for name in stamped():
            h.update(name.encode() + b"\0" + (ROOT / name).read_bytes() + b"\0")
        _digests[key] = h.hexdigest()
    return _digests[key]


def stamped() -> list[str]:
    """The files the stamp covers: KERNEL_MODULES and every module of the package they import.
    A kernel freezes the globals it reads when it is compiled, so a constant or a function a
    kernel module imports from a plain module (``mdp.robot``'s, ``labels.tables``') is part of its
    machine code too: editing that module must recompile it."""
    names = list(KERNEL_MODULES)
    for name in KERNEL_MODULES:
        for node in ast.walk(ast.parse((ROOT / name).read_bytes())):
            if isinstance(node, ast.ImportFrom) and node.module and not node.level:
                dotted = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                dotted = [a.name for a in node.names]
            else:
                continue
            for d in dotted:
                path = _file_of(d)
                if path is not None and path not in names:
                    names.append(path)
    return names


def _file_of(dotted: str) -> str | None:
    """The file of a module of the package (relative to ROOT), or None for another's."""
    parts = dotted.split(".")
    if parts[0] == ROOT.name:
        parts = parts[1:]
    for rel in ("/".join(parts) + ".py", "/".join([*parts, "__init__.py"])):
        if parts and (ROOT / rel).is_file():
            return rel
    return None


@intrinsic
def prefetch(typingctx, arr, index):
    """prefetch(arr, i) in a kernel asks the CPU to bring arr[i] (arr[i, 0] of a 2-D arr) into its
    caches, for a read soon. A hint with no effect on results: it never faults, even out of range."""

    def codegen(context, builder, signature, args):
        aryty, idxty = signature.args
        ary = context.make_array(aryty)(context, builder, args[0])
        idx = [context.cast(builder, args[1], idxty, types.intp)]
        idx += [context.get_constant(types.intp, 0)] * (aryty.ndim - 1)
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, idx, wraparound=False)
        i8p, i32 = ir.IntType(8).as_pointer(), ir.IntType(32)
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32]),
                                            "llvm.prefetch.p0i8")
        builder.call(fn, [builder.bitcast(ptr, i8p), i32(0), i32(3), i32(1)])  # read, keep in all levels, data
        return context.get_dummy_value()

    return types.void(arr, index), codegen


def _numba(name: str):
    """A class of numba's caching module, by its public name or (numba < 0.63) its private one."""
    return getattr(caching, name, None) or getattr(caching, "_" + name)


class _Stamped:
    """A numba cache locator for this package's files: numba's stamp plus ``digest()``."""

    def get_source_stamp(self):
        return super().get_source_stamp(), digest()

    @classmethod
    def from_function(cls, py_func, py_file):
        try:
            Path(py_file).resolve().relative_to(ROOT)
        except (OSError, ValueError):
            return None  # not voiopt's: numba's own locators take it
        return super().from_function(py_func, py_file)


def _install() -> None:
    locators = _numba("CacheImpl")._locator_classes
    if any(issubclass(c, _Stamped) for c in locators):
        return
    ours = [type(f"Voiopt{base.__name__.lstrip('_')}", (_Stamped, base), {"__module__": __name__})
            for base in (_numba(n) for n in ("UserProvidedCacheLocator", "InTreeCacheLocator", "UserWideCacheLocator"))]
    locators[:0] = ours  # the user's NUMBA_CACHE_DIR first, as numba's own order has it


_install()
