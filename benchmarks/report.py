"""The results tables in docs/results/: each benchmark writes what it printed there, under a header.

A benchmark's ``__main__`` block calls ``report.run(name, main)``: what ``main`` prints to
standard output is shown as usual and, when it returns, written atomically to
``docs/results/<name>.md`` (or to the folder named by ``VOIOPT_RESULTS_DIR``) under a header that
gives the command, the commit, the date and the machine. Lines that start with ``|`` stay
Markdown tables; every other line goes into a text block. ``VOIOPT_RESULTS_DIR=-`` writes nothing
(a quick look that should not replace the table of a full run), and ``VOIOPT_RESULTS_NAME``
replaces ``<name>`` (one benchmark run at several settings, each its own table).

A table whose rows were copied from the docs before the benchmarks wrote their own carries
``Source: carried over ...`` in its header (``carried_over`` writes one): regenerate it with
``make results``.
"""

from __future__ import annotations

import contextlib
import datetime
import io
import os
import platform
import shlex
import subprocess
import sys
from collections.abc import Callable
from importlib import metadata
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "docs" / "results"
MEASURED = "measured by the command above"
CARRIED = ("carried over from the docs before the tables were generated; regenerate with make results "
           "(the fields above are what the docs recorded of that run)")
#: the header fields every table has, in order
FIELDS = ("Command", "Commit", "Date", "Machine", "Software", "Source")
VERSIONS = ("numpy", "numba", "highspy")


def commit() -> str:
    """``git rev-parse --short HEAD``, with ``+dirty`` when the work tree has changes."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                              text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown (not a git checkout)"
    return head + ("+dirty" if dirty else "")


def _cpu_model() -> str:
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor() or platform.machine()


def _memory() -> str:
    with contextlib.suppress(OSError, ValueError, IndexError):
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                return f"{int(line.split()[1]) / 2**20:.1f} GiB"
    return "unknown memory"


def machine() -> str:
    """CPU model, cores, memory and OS of this machine."""
    load = f", load average {os.getloadavg()[0]:.1f} when written" if hasattr(os, "getloadavg") else ""
    return f"{_cpu_model()}, {os.cpu_count()} cores, {_memory()}, {platform.system()} {platform.release()}{load}"


def software() -> str:
    """Python and the numpy, numba and highspy versions."""
    parts = [f"Python {platform.python_version()}"]
    for name in VERSIONS:
        try:
            parts.append(f"{name} {metadata.version(name)}")
        except metadata.PackageNotFoundError:
            parts.append(f"{name} not installed")
    return ", ".join(parts)


def header(name: str, command: str, source: str = MEASURED, **given: str) -> str:
    """The header of ``docs/results/<name>.md``: one bullet per field of ``FIELDS``.

    ``given`` replaces a field (``Commit=``, ``Date=``, ``Machine=``, ``Software=``) for a table
    carried over from a run that this process did not make."""
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    values = (f"`{command}`", given.get("Commit") or commit(), given.get("Date") or now,
              given.get("Machine") or machine(), given.get("Software") or software(), source)
    lines = [f"# {name}", "", "Written by the benchmark itself (benchmarks/report.py); do not edit by hand.", ""]
    lines += [f"- {field}: {value}" for field, value in zip(FIELDS, values, strict=True)]
    return "\n".join(lines) + "\n"


def body(text: str) -> str:
    """Printed output as Markdown: runs of ``|`` lines stay tables, the rest goes into text blocks."""
    out, block, table = [], [], None
    for line in text.rstrip().splitlines():
        is_row = line.lstrip().startswith("|")
        if table is None or is_row != table:
            if block:
                out.append(_render(block, table))
            block, table = [], is_row
        block.append(line.strip() if is_row else line)
    if block:
        out.append(_render(block, table))
    return "\n\n".join(out) + "\n"


def _render(lines: list[str], table: bool) -> str:
    if table:
        return "\n".join(lines)
    while lines and not lines[-1].strip():
        lines.pop()
    while lines and not lines[0].strip():
        lines.pop(0)
    return "```text\n" + "\n".join(lines) + "\n```" if lines else ""


def write(name: str, command: str, text: str, source: str = MEASURED, **given: str) -> Path | None:
    """Write ``text`` (printed output) as ``<results>/<name>.md``, atomically; None when disabled."""
    folder = os.environ.get("VOIOPT_RESULTS_DIR", str(RESULTS))
    if folder == "-":
        return None
    from voiopt.runtime.files import atomic_write

    path = Path(folder) / f"{name}.md"
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_write(path) as f:
            f.write(header(name, command, source, **given) + "\n" + body(text))
    except OSError as e:
        raise SystemExit(f"{path}: cannot write the results table: {e.strerror or e}") from None
    return path


def combine(name: str, parts: list[Path]) -> Path | None:
    """One table from several runs' tables (one benchmark at several settings): their commands
    joined in the header, each run's body under its own command. The machine, software, commit
    and date are this process's, taken when the runs have just finished."""
    commands, bodies = [], []
    for part in parts:
        head, _, rest = part.read_text(encoding="utf-8").partition("\n\n- Command: `")
        command, _, rest = rest.partition("`\n")
        commands.append(command)
        bodies.append(f"Run: `{command}`\n\n" + rest.split("\n\n", 1)[1].strip())
    folder = os.environ.get("VOIOPT_RESULTS_DIR", str(RESULTS))
    if folder == "-":
        return None
    from voiopt.runtime.files import atomic_write

    path = Path(folder) / f"{name}.md"
    try:
        with atomic_write(path) as f:
            f.write(header(name, "; ".join(commands)) + "\n" + "\n\n".join(bodies) + "\n")
    except OSError as e:
        raise SystemExit(f"{path}: cannot write the results table: {e.strerror or e}") from None
    return path


class _Tee(io.TextIOBase):
    def __init__(self, stream):
        self.stream, self.buffer_ = stream, io.StringIO()

    def write(self, s: str) -> int:
        self.buffer_.write(s)
        return self.stream.write(s)

    def flush(self) -> None:
        self.stream.flush()


def run(name: str, main: Callable[[], int | None]) -> int:
    """Run a benchmark's ``main``, showing and keeping what it prints; then write its table.

    Returns main's exit status. Nothing is written when main raises (Ctrl-C, an error)."""
    command = "python " + shlex.join([f"benchmarks/{Path(sys.argv[0]).name}", *sys.argv[1:]])
    tee = _Tee(sys.stdout)
    with contextlib.redirect_stdout(tee):
        status = main()
    path = write(os.environ.get("VOIOPT_RESULTS_NAME", name), command, tee.buffer_.getvalue())
    if path is not None:
        print(f"table written to {path}", file=sys.stderr)
    return int(status or 0)
