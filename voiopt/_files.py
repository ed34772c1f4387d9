"""Files: read JSON with clear errors, and write every output atomically with the umask."""

from __future__ import annotations

import csv
import hashlib
import json
import os
import re
import tempfile
from collections.abc import Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from voiopt.errors import InstanceError, OptionError


def _reject_constant(name: str) -> float:
    raise ValueError(f"{name} is not allowed")


def loads_json(text: str, error: type[Exception] = InstanceError, where: str = "") -> Any:
    """Decode JSON; a syntax error names the line and column. NaN/Infinity are rejected."""
    prefix = f"{where}: " if where else ""
    try:
        return json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as e:
        raise error(f"{prefix}invalid JSON at line {e.lineno}, column {e.colno}: {e.msg}") from None
    except RecursionError:
        raise error(f"{prefix}invalid JSON: nested too deeply") from None
    except ValueError as e:  # NaN / Infinity
        raise error(f"{prefix}invalid JSON: {e}") from None


def read_json(path: str | os.PathLike, error: type[Exception] = InstanceError) -> Any:
    """Read a JSON file; a syntax error names the file, line and column."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise error(f"{p}: no such file") from None
    except IsADirectoryError:
        raise error(f"{p}: is a directory, not a JSON file") from None
    except (OSError, UnicodeDecodeError) as e:
        raise error(f"{p}: cannot read: {e}") from None
    return loads_json(text, error, str(p))


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextmanager
def atomic_write(path: str | os.PathLike, *, binary: bool = False, newline: str | None = None):
    """Write through a temporary file beside ``path``, renamed over it only when the block
    finishes: a reader sees the old file or the new one, never half of one. The file gets the
    permissions of a plain open() (0666 less the umask), not mkstemp's 0600."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
    try:
        os.fchmod(fd, 0o666 & ~_umask())
        if binary:
            f = os.fdopen(fd, "wb")
        else:
            f = os.fdopen(fd, "w", encoding="utf-8", newline=newline)
        with f:
            yield f
        os.replace(tmp, p)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_json_atomic(path: str | os.PathLike, obj: Any) -> None:
    """Write JSON atomically (see ``atomic_write``)."""
    with atomic_write(path) as f:
        json.dump(obj, f, indent=2, allow_nan=False)
        f.write("\n")


def write_csv(path: Path, rows: Sequence[dict[str, Any]], columns: Sequence[str], header: Sequence[str] = ()) -> None:
    """A CSV written atomically; ``header`` lines go first as '# ...' comments."""
    with atomic_write(path, newline="") as f:
        for line in header:
            f.write(f"# {line}\n")
        w = csv.DictWriter(f, fieldnames=list(columns))
        w.writeheader()
        for row in rows:
            w.writerow({k: ("" if row.get(k) is None else row[k]) for k in columns})


def read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, encoding="utf-8") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def safe_name(name: str) -> str:
    """A file-name stem for an instance name: letters, digits, '.', '_' and '-' only, no
    leading dot, at most 80 characters; where that changed the name, a hash of the full name is
    appended so that two names never share a file."""
    stem = re.sub(r"[^A-Za-z0-9._-]", "_", name).lstrip(".")[:80] or "instance"
    if stem != name:
        stem += "-" + hashlib.sha256(name.encode("utf-8", "surrogatepass")).hexdigest()[:10]
    return stem


def check_output_file(path: str | os.PathLike, what: str = "-o/--output") -> Path:
    """Before any work: the file can be written (its folder exists and is writable, and it is
    not itself a folder); an OptionError naming the path otherwise."""
    p = Path(path)
    if p.is_dir():
        raise OptionError(f"{what}: {str(p)!r} is a directory; give a file name")
    parent = p.parent
    if not parent.is_dir():
        raise OptionError(f"{what}: the folder {str(parent)!r} of {str(p)!r} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK) or (p.exists() and not os.access(p, os.W_OK)):
        raise OptionError(f"{what}: {str(p)!r} cannot be written (no permission)")
    return p


def check_output_dir(path: str | os.PathLike, what: str = "-o/--output") -> Path:
    """Before any work: the folder exists and is writable, or can be made in a writable parent."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise OptionError(f"{what}: {str(p)!r} is a file, not a folder")
    if p.is_dir():
        if not os.access(p, os.W_OK | os.X_OK):
            raise OptionError(f"{what}: the folder {str(p)!r} cannot be written (no permission)")
        return p
    if not p.parent.is_dir():
        raise OptionError(f"{what}: the folder {str(p.parent)!r} of {str(p)!r} does not exist")
    if not os.access(p.parent, os.W_OK | os.X_OK):
        raise OptionError(f"{what}: the folder {str(p)!r} cannot be made in {str(p.parent)!r} (no permission)")
    return p
