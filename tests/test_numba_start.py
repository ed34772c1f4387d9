"""The command line starts numba without its BLAS check; the library leaves numba as it is.

Each case runs in a fresh process, because numba initialises once per process."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

CASE = str(Path(__file__).resolve().parents[1] / "instances" / "case-study.json")

AFTER = """
import numba.np.arraymath as arraymath
import scipy.linalg.cython_blas  # imports normally once numba has started
print(arraymath._HAVE_BLAS)
"""


def _fresh(code: str) -> str:
    return subprocess.run([sys.executable, "-c", code + AFTER], capture_output=True, text=True, check=True,
                          timeout=300).stdout.split()[-1]


@pytest.mark.parametrize("method", ["qlearning", "dp"])
def test_the_command_line_skips_numba_blas_check_and_scipy_linalg_still_imports(tmp_path, method):
    out = tmp_path / "r.json"
    cli = (f"import sys; sys.argv = ['voiopt', 'solve', {CASE!r}, '--method', {method!r}, '--episodes', '10', "
           f"'--quiet', '-o', {str(out)!r}]\n"
           "from voiopt.cli import main as cli\n"
           "try:\n    cli.run()\nexcept SystemExit as e:\n    assert e.code == 0, e.code\n")
    if method == "dp":
        cli = cli.replace(", '--episodes', '10'", "")
    assert _fresh(cli) == "False"
    r = json.loads(out.read_text())
    assert r["status"] in ("optimal", "feasible") and r["plan"]["positions"]


def test_the_library_leaves_numba_blas_check_alone():
    lib = ("import voiopt\nfrom voiopt.solvers import qlearning\n"
           f"qlearning.solve(voiopt.load({CASE!r}), episodes=10)\n")
    assert _fresh(lib) == "True"


def test_the_command_line_imports_numba_only_for_commands_that_use_it():
    code = "import sys\nimport voiopt.cli.main\nprint('numba' in sys.modules)\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120)
    assert out.stdout.split()[-1] == "False"  # validate, generate, evaluate... start without it


def test_validating_a_fleet_with_ends_starts_numba_the_same_way(tmp_path):
    """Validation decides with a numba table whether robots with ends can finish together
    (voiopt.grid.joint): from the command line that start skips the BLAS check too."""
    fleet = tmp_path / "fleet.json"
    fleet.write_text(json.dumps({"area": {"width": 2, "height": 1}, "horizon": 6, "sensors": [{"position": [1, 0.5], "rho": 0.5}],
                                 "robots": [{"start": [0, 0], "end": [2, 0]}, {"start": [2, 0], "end": [0, 0]}]}))
    cli = (f"import sys; sys.argv = ['voiopt', 'validate', {str(fleet)!r}]\n"
           "from voiopt.cli import main as cli\n"
           "try:\n    cli.run()\nexcept SystemExit as e:\n    assert e.code == 0, e.code\n"
           "assert 'voiopt.grid.joint' in sys.modules\n")
    assert _fresh(cli) == "False"
