"""numba's disk cache of voiopt's kernels is stamped with every kernel module (voiopt/jit.py):
a kernel that inlines a kernel of another module is recompiled when only that module changes,
and loaded from the cache when nothing changed."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np

from voiopt.runtime import jit
from voiopt.solvers.labels import kernels

PACKAGE = Path(jit.__file__).resolve().parent.parent  # voiopt/, above runtime/

RUN = """
import sys
from pathlib import Path
import numpy as np

from voiopt.runtime import jit
jit.ROOT = Path(sys.argv[1]).resolve()
jit.KERNEL_MODULES = ("callee.py", "caller.py")
sys.path.insert(0, sys.argv[1])
import caller
print(caller.run(1))
"""

CALLER = """
from callee import step
from voiopt.runtime.jit import njit

@njit(cache=True)
def run(x):
    return step(x)
"""

CALLEE = """
from voiopt.runtime.jit import njit

@njit(cache=True, inline="always")
def step(x):
    return x + {}
"""


def test_every_module_that_defines_kernels_is_stamped_and_takes_njit_from_jit():
    defines = set()
    for path in PACKAGE.rglob("*.py"):
        name = path.relative_to(PACKAGE).as_posix()
        text = path.read_text()
        if name in ("runtime/jit.py", "runtime/numba_start.py"):  # numba_start compiles one trivial kernel to start numba
            continue
        if re.search(r"^\s*@njit\(", text, re.M):
            defines.add(name)
        assert not re.search(r"^\s*(import numba|from numba\b)", text, re.M), f"{name} imports numba itself"
    assert defines == set(jit.KERNEL_MODULES)
    assert isinstance(kernels.expand._cache._impl._locator, jit._Stamped)


def _run(folder: Path) -> tuple[str, str]:
    out = subprocess.run([sys.executable, "-c", RUN, str(folder)], capture_output=True, text=True, check=True,
                         timeout=300, env={**_environ(), "NUMBA_DEBUG_CACHE": "1"})
    return out.stdout.splitlines()[-1], out.stdout


def _environ() -> dict:
    import os

    return {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_CACHE")}


def test_editing_only_the_inlined_module_recompiles_its_caller(tmp_path):
    (tmp_path / "caller.py").write_text(textwrap.dedent(CALLER))
    (tmp_path / "callee.py").write_text(textwrap.dedent(CALLEE.format(1)))
    value, _ = _run(tmp_path)
    assert value == "2"
    value, log = _run(tmp_path)  # nothing changed: the caller's machine code comes from the cache
    assert value == "2" and "data loaded from" in log and "caller.run" in log
    (tmp_path / "callee.py").write_text(textwrap.dedent(CALLEE.format(5)))  # caller.py is untouched
    value, _ = _run(tmp_path)
    assert value == "6"


def test_prefetch_is_a_hint_that_changes_no_result():
    @jit.njit
    def total(vector, matrix):
        s = 0.0
        for i in range(vector.shape[0] + 64):  # past the end too: a prefetch never faults
            jit.prefetch(vector, i)
            jit.prefetch(matrix, i % matrix.shape[0])
        for i in range(vector.shape[0]):
            s += vector[i]
        return s + matrix.sum()

    vector, matrix = np.arange(1000.0), np.arange(24, dtype=np.uint64).reshape(8, 3)
    assert total(vector, matrix) == vector.sum() + matrix.sum()


PLAIN_CALLER = """
from offsets import OFFSET
from voiopt.runtime.jit import njit

@njit(cache=True)
def run(x):
    return x + OFFSET
"""


def test_editing_only_a_plain_module_a_kernel_imports_recompiles_the_kernel(tmp_path):
    """A kernel freezes the globals it reads: a constant imported from a module without kernels
    (offsets.py, outside KERNEL_MODULES) is compiled in. The stamp covered only the kernel
    modules, so editing offsets.py alone left the old constant in the cached machine code."""
    run = RUN.replace('jit.KERNEL_MODULES = ("callee.py", "caller.py")', 'jit.KERNEL_MODULES = ("caller.py",)')
    (tmp_path / "caller.py").write_text(textwrap.dedent(PLAIN_CALLER))
    (tmp_path / "offsets.py").write_text("OFFSET = 1\n")

    def value() -> str:
        out = subprocess.run([sys.executable, "-c", run, str(tmp_path)], capture_output=True, text=True, check=True,
                             timeout=300, env=_environ())
        return out.stdout.splitlines()[-1]

    assert value() == "2"
    (tmp_path / "offsets.py").write_text("OFFSET = 5\n")  # caller.py is untouched
    assert value() == "6"


def test_the_stamp_covers_the_plain_modules_the_package_kernels_import():
    names = jit.stamped()
    assert set(jit.KERNEL_MODULES) <= set(names)
    assert {"mdp/robot.py", "solvers/labels/tables.py", "grid/paths.py"} <= set(names)
    assert all((PACKAGE / n).is_file() for n in names)
