"""Files: read JSON with clear errors, and write every output atomically with the umask."""

from __future__ import annotations

import csv
import hashlib
import json
import os
import re
import secrets
import stat
import sys
import tempfile
from collections.abc import Sequence
from contextlib import contextmanager
from itertools import chain
from pathlib import Path
from typing import Any

import numpy as np

from voiopt.errors import InstanceError, OptionError, VoioptError
from voiopt.runtime.checker import show
from voiopt.runtime.stop import sigterm_raises

# Limits of every JSON file voiopt reads. A plan at the horizon cap (10**6 slots) has about
# 10**6 lists and 3 * 10**6 commas and, pretty-printed inside a result, about 60 MB; the
# limits leave room for that and keep the decoded objects of a hostile file of this size to
# a few hundred MB (an instance file is far smaller: 10**4 sensors are about 3 MB).
MAX_JSON_BYTES = 128 * 2**20
MAX_JSON_DEPTH = 100  # an instance nests 4 levels, a result 6
MAX_JSON_CONTAINERS = 2**21  # lists and objects
MAX_JSON_ITEMS = 2**22  # commas, a bound on the number of values
MAX_INT_DIGITS = 1000  # longer integers are kept as HugeInt (Python refuses > 4300 digits)

# A JSON string, or an unterminated one up to the end of the text (so a match always
# succeeds and the scan stays linear), and a run of anything that is not a bracket.
_STRING = re.compile(r'"[^"\\]*(?:\\(?:.|\Z)[^"\\]*)*(?:"|\Z)', re.S)
_NOT_BRACKETS = bytes(c for c in range(256) if chr(c) not in "[]{}")
_HUGE = 10**MAX_INT_DIGITS


class HugeInt(int):
    """An integer literal of more than MAX_INT_DIGITS digits, kept as +-10**MAX_INT_DIGITS
    (far beyond any cap and the float range) with its digit count, so that validation names
    the field (``must be finite, got an integer of 5000 digits``) instead of the decoder
    failing on Python's limit of 4300 digits."""

    digits: int

    def __new__(cls, text: str) -> HugeInt:
        sign = -1 if text.startswith("-") else 1
        obj = super().__new__(cls, sign * _HUGE)
        obj.digits = len(text.lstrip("-"))
        return obj


def _parse_int(text: str) -> int:
    return int(text) if len(text) <= MAX_INT_DIGITS else HugeInt(text)


def _reject_constant(name: str) -> float:
    raise ValueError(f"{name} is not allowed")


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict:
    """An object's members; a name given twice is refused (JSON leaves its meaning open, and
    Python's decoder would keep the last one silently: a second "rho" would hide the first)."""
    d = dict(pairs)
    if len(d) != len(pairs):
        seen = set()
        twice = next(k for k, _ in pairs if k in seen or seen.add(k))
        raise ValueError(f"the key {show(twice)} is given twice in one object")
    return d


def _depth(brackets: bytes) -> int:
    """The deepest nesting of a string of brackets, in C-speed chunks of 2**20."""
    deepest = level = 0
    data = np.frombuffer(brackets, dtype=np.uint8)
    for i in range(0, len(data), 2**20):
        chunk = data[i : i + 2**20]
        steps = np.where((chunk == ord("[")) | (chunk == ord("{")), 1, -1).astype(np.int32)
        levels = np.cumsum(steps, dtype=np.int64) + level
        deepest, level = max(deepest, int(levels.max())), int(levels[-1])
    return deepest


def _check_size(text: str) -> str | None:
    """Why ``text`` is too large or nested too deeply to decode, or None. Linear and cheap
    (regular expressions and numpy, no Python loop over characters), and it does not rely on
    the recursion limit: json's C decoder overflows the C stack, a segfault rather than a
    RecursionError, when some library has raised the limit and the nesting is deep enough."""
    if len(text) > MAX_JSON_BYTES:
        return f"more than {MAX_JSON_BYTES} characters (the limit of a voiopt JSON file), got {len(text)}"
    if text.count(",") > MAX_JSON_ITEMS:
        return f"more than {MAX_JSON_ITEMS} values (a plan has about 3 per slot, at most 1000000 slots), got {text.count(',')} commas"
    if text.count("[") + text.count("{") <= min(MAX_JSON_DEPTH, MAX_JSON_CONTAINERS):
        return None
    brackets = _STRING.sub("", text).encode("utf-8", "replace").translate(None, _NOT_BRACKETS)
    opened = brackets.count(b"[") + brackets.count(b"{")
    if opened > MAX_JSON_CONTAINERS:
        return f"more than {MAX_JSON_CONTAINERS} lists and objects (a plan has one per slot, at most 1000000 slots), got {opened}"
    depth = _depth(brackets)
    if depth > MAX_JSON_DEPTH:
        return f"nested more than {MAX_JSON_DEPTH} levels deep (a voiopt file nests at most 6), got {depth}"
    return None


def _decode(text: str) -> Any:
    """json.loads, with integers of more than MAX_INT_DIGITS digits kept as HugeInt. The
    hook is slow, so it is used only when the fast decoder refuses a long integer, or when
    Python's limit on integer digits is off (then int() of a long literal is quadratic)."""
    limit = getattr(sys, "get_int_max_str_digits", lambda: 0)()
    if 0 < limit <= 10 * MAX_INT_DIGITS:
        try:
            return json.loads(text, parse_constant=_reject_constant, object_pairs_hook=_unique_keys)
        except json.JSONDecodeError:
            raise
        except ValueError as e:
            if "integer string conversion" not in str(e):
                raise
    return json.loads(text, parse_constant=_reject_constant, parse_int=_parse_int, object_pairs_hook=_unique_keys)


def loads_json(text: str, error: type[Exception] = InstanceError, where: str = "") -> Any:
    """Decode JSON; a syntax error names the line and column. NaN/Infinity are rejected;
    texts too large or nested too deeply are refused before decoding (see the limits above)."""
    prefix = f"{where}: " if where else ""
    why = _check_size(text)
    if why:
        raise error(f"{prefix}invalid JSON: {why}")
    try:
        return _decode(text)
    except json.JSONDecodeError as e:
        # the phrase whole: "Unterminated string starting at" ends where the position begins
        raise error(f"{prefix}invalid JSON: {e.msg.removesuffix(' at')} at line {e.lineno}, column {e.colno}") from None
    except RecursionError:
        raise error(f"{prefix}invalid JSON: nested too deeply") from None
    except ValueError as e:  # NaN / Infinity, a key given twice
        raise error(f"{prefix}invalid JSON: {e}") from None


def read_json(path: str | os.PathLike, error: type[Exception] = InstanceError) -> Any:
    """Read a JSON file; a syntax error names the file, line and column. At most
    MAX_JSON_BYTES are read, so a huge file or a device such as /dev/zero is refused."""
    p, name = Path(path), os.fsdecode(path)  # messages show the path as given ("./a.json", not "a.json")
    try:
        with open(p, "rb") as f:
            data = f.read(MAX_JSON_BYTES + 1)
    except FileNotFoundError:
        raise error(f"{name}: no such file") from None
    except IsADirectoryError:
        raise error(f"{name}: is a directory, not a JSON file") from None
    except OSError as e:
        raise error(f"{name}: cannot read: {e.strerror or e}") from None
    if len(data) > MAX_JSON_BYTES:
        raise error(f"{name}: invalid JSON: larger than {MAX_JSON_BYTES} bytes (the limit of a voiopt JSON file)")
    try:
        text = data.decode("utf-8-sig")  # a byte order mark, as some editors write, is skipped
    except UnicodeDecodeError as e:
        raise error(f"{name}: cannot read: not UTF-8 text (byte {e.start})") from None
    return loads_json(text, error, name)


@contextmanager
def reading(where: str | os.PathLike, error: type[Exception] = VoioptError):
    """A block that reads what ``where`` names: an ``error`` raised in it is raised again with
    ``where`` in front, so the message names the file (one line, the same class)."""
    try:
        yield
    except error as e:
        raise type(e)(f"{os.fspath(where)}: {e}") from None


@contextmanager
def atomic_write(path: str | os.PathLike, *, binary: bool = False, newline: str | None = None):
    """Write through a temporary file beside ``path``, renamed over it only when the block
    finishes: a reader sees the old file or the new one, never half of one. The file gets the
    permissions of a plain open() (0666 less the umask). The temporary file's name is drawn
    before it is made, so that a Ctrl-C at any moment of the making, too, removes it.

    A symbolic link keeps being one: the file it points to is replaced. Something that exists
    and is neither a file nor a folder (a device such as /dev/null, a named pipe) is written
    into as open() would, not replaced by a file."""
    p, special = _destination(path)
    mode = {"mode": "wb"} if binary else {"mode": "w", "encoding": "utf-8", "newline": newline}
    if special:
        fd = _descriptor(p)  # /dev/stdout and the like: the process's own descriptor, as a shell writes to it
        if fd is not None:
            sys.stdout.flush()
        try:
            raw = os.dup(fd) if fd is not None else os.open(p, os.O_WRONLY | os.O_APPEND | getattr(os, "O_BINARY", 0))
            with os.fdopen(raw, **mode) as f:
                yield f
        except OSError as e:
            raise named(e, p) from None
        return
    create = lambda tmp: os.fdopen(  # noqa: E731
        os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666), **mode)
    with _renamed_over(p, lambda token: f".{p.name}.{token}.tmp", create) as f, f:
        yield f


def named(e: OSError, path: str | os.PathLike) -> OSError:
    """An error of writing ``path`` that says which file: write() and close() name none (a full
    disk said only "[Errno 28] No space left on device"). One that names a file is kept."""
    if e.filename is not None or os.fspath(path) in str(e):
        return e
    return OSError(e.errno, f"cannot write {os.fspath(path)}: {e.strerror or e}")  # errno picks the subclass


@contextmanager
def _renamed_over(p: Path, name, make=lambda tmp: tmp):
    """The temporary file of both writers: draws a fresh name beside ``p`` (``name(token)``),
    yields ``make(tmp)`` (which may create the file: one that exists, another's, draws a new
    name), then renames the temporary file over ``p`` when the block finishes, and removes it
    if the block does not (a SIGTERM raises meanwhile, so it is removed then too). The name is
    held before the file is made, so that a Ctrl-C at any moment of the making removes it."""
    p.parent.mkdir(parents=True, exist_ok=True)
    tmp = None
    with sigterm_raises():
        try:
            while True:
                tmp = p.parent / name(secrets.token_hex(4))
                try:
                    made = make(tmp)
                    break
                except FileExistsError:
                    tmp = None
            yield made
            os.replace(tmp, p)
        except OSError as e:  # a full disk: the error names the file, which writing and closing do not say
            if tmp is not None:
                tmp.unlink(missing_ok=True)
            raise named(e, p) from None
        except BaseException:
            if tmp is not None:
                tmp.unlink(missing_ok=True)
            raise


def _destination(path: str | os.PathLike) -> tuple[Path, bool]:
    """Where an output goes, and whether it is written into as it is (``open(path)``) rather
    than replaced: a device or a named pipe, or anything under /dev or /proc (/dev/stdout is a
    link to the file or pipe behind the shell's redirection, which must not be replaced). A
    link to an existing file: that file, replaced (the link stays); any other path, itself."""
    given = Path(path)
    try:
        st = os.stat(given)  # through links
    except OSError:
        return given, False  # nothing there yet, or a dangling link (replaced, as a file would be)
    hops = [os.readlink(given)] if given.is_symlink() else []
    if not (stat.S_ISREG(st.st_mode) or stat.S_ISDIR(st.st_mode)) or \
            any(str(x).startswith(("/dev/", "/proc/")) for x in (os.path.abspath(given), *hops)):
        return given, True
    return (Path(os.path.realpath(given)) if hops else given), False


def _descriptor(path: Path) -> int | None:
    """The descriptor that /dev/stdout, /dev/stderr, /dev/fd/N or /proc/self/fd/N names."""
    m = re.fullmatch(r"/dev/(stdout|stderr)|/(?:dev/fd|proc/self/fd)/(\d+)", os.path.abspath(path))
    return None if m is None else {"stdout": 1, "stderr": 2}.get(m.group(1) or "", int(m.group(2) or 0))


@contextmanager
def atomic_path(path: str | os.PathLike):
    """For a writer that takes a file name (HiGHS's writeModel): yields a temporary name beside
    ``path``, with its suffix (which picks the format), renamed over ``path`` when the block
    finishes and removed if it does not, as ``atomic_write`` does (symbolic links and special
    files likewise)."""
    p, special = _destination(path)
    if special:
        yield p
        return
    suffix = Path(path).suffix  # the name the user gave picks the format, not a link's target
    with _renamed_over(p, lambda token: f".{p.stem}.{token}.tmp{suffix}") as tmp:
        yield tmp


def write_json_atomic(path: str | os.PathLike, obj: Any) -> None:
    """Write JSON atomically (see ``atomic_write``), indented as ``dumps_json``."""
    with atomic_write(path) as f:  # encoded inside: a SIGTERM while encoding is handled as while writing
        f.write(dumps_json(obj))
        f.write("\n")


_SCALAR = {int, float, bool, type(None)}  # their JSON has no comma, bracket or quote
LONG_LIST = 256  # lists from which ``dumps_json`` lays them out itself
SWAP_DEPTH = 50  # how deep it looks for them (a result's plans are 3 to 4 deep)


def dumps_json(obj: Any) -> str:
    """``json.dumps(obj, indent=2, allow_nan=False)``, the same text, fast for long lists of
    numbers and of pairs of numbers (a plan's positions and schedule). With an indent, json
    encodes in Python, a few microseconds a number: the result of a plan of T = 10^6 slots,
    six million lines, took 4 to 10 s to write after the solve had stopped. Such a list is
    encoded compactly by json's C encoder and laid out by string replacement (its numbers
    contain no comma or bracket); the rest of the object goes through json as before, with a
    placeholder in the list's place (tests/test_files.py compares the two on random objects)."""
    lists: dict[str, str] = {}
    tag = f"voiopt-{secrets.token_hex(8)}-"

    def swap(o: Any, depth: int) -> Any:
        if depth > SWAP_DEPTH:  # left to json as it is (deep nesting, a circular reference)
            return o
        if isinstance(o, dict):
            return {k: swap(v, depth + 1) for k, v in o.items()}
        if isinstance(o, (list, tuple)):
            kind = _kind(o)
            try:
                compact = None if kind is None else json.dumps(o, separators=(",", ":"), allow_nan=False)
            except ValueError:  # a NaN: json's own encoder below names the value
                compact = None
            if compact is None:
                return [swap(v, depth + 1) for v in o]
            name = f"{tag}{len(lists)}"
            lists[json.dumps(name)] = compact, kind
            return name
        return o

    text = json.dumps(swap(obj, 0), indent=2, allow_nan=False)
    if not lists:
        return text
    out, at = [], 0
    for line_start, key, line_indent in _placeholders(text, lists):
        out.append(text[at:line_start])
        compact, kind = lists[key]
        out.append(_lay_out(compact, kind, line_indent))
        at = line_start + len(key)
    out.append(text[at:])
    return "".join(out)


def _kind(o: list | tuple) -> str | None:
    """'flat' for a long list of scalars, 'pairs' for one of non-empty lists of scalars."""
    if len(o) < LONG_LIST:
        return None
    types = set(map(type, o))
    if types <= _SCALAR:
        return "flat"
    if types <= {list, tuple} and min(map(len, o)) > 0 and set(map(type, chain.from_iterable(o))) <= _SCALAR:
        return "pairs"
    return None


def _placeholders(text: str, lists: dict) -> list[tuple[int, str, int]]:
    """(offset, placeholder, indent of its line) of each placeholder in text, in order."""
    found = []
    for key in lists:
        i = text.index(key)
        line = text[text.rfind("\n", 0, i) + 1:i]
        found.append((i, key, len(line) - len(line.lstrip(" "))))
    return sorted(found)


def _lay_out(compact: str, kind: str, indent: int) -> str:
    """The indent=2 layout of a compact list whose line starts ``indent`` spaces in."""
    e1, e2 = "\n" + " " * (indent + 2), "\n" + " " * (indent + 4)
    if kind == "flat":
        return "[" + e1 + compact[1:-1].replace(",", "," + e1) + "\n" + " " * indent + "]"
    inner = compact[2:-2].replace("],[", "\0").replace(",", "," + e2).replace("\0", e1 + "]," + e1 + "[" + e2)
    return "[" + e1 + "[" + e2 + inner + e1 + "]" + "\n" + " " * indent + "]"


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


def check_output_file(path: str | os.PathLike, what: str = "-o/--output",
                      inputs: Sequence[tuple[str, str | os.PathLike | None]] = ()) -> Path:
    """Before any work: the file can be written (its folder exists and is writable, and it is
    not itself a folder, nor one of the command's ``inputs``, (option, path) pairs, which the
    output would replace); an OptionError naming the path otherwise."""
    if str(path).endswith(("/", os.sep)):  # Path() would drop the slash and write a file of that name
        raise OptionError(f"{what}: {str(path)!r} names a folder (it ends in '/'); give a file name")
    p = _named(path, what, NAME_MAX - TMP_EXTRA)
    if p.is_dir():
        raise OptionError(f"{what}: {str(p)!r} is a directory; give a file name")
    for option, given in inputs:
        if given is not None and p.exists() and Path(given).exists() and p.samefile(given):
            raise OptionError(f"{what}: {str(p)!r} is the {option} this command reads; writing it would replace "
                              "it: give another file name")
    dest, special = _destination(p)  # where atomic_write makes its temporary file: a link's target's folder
    if special:  # written into, not replaced
        if not os.access(p, os.W_OK):
            raise OptionError(f"{what}: {str(p)!r} cannot be written (no permission)")
        return p
    _check_parent(dest, what)
    if (dest.exists() and not os.access(dest, os.W_OK)) or not _can_create_in(dest.parent):
        raise OptionError(f"{what}: {str(p)!r} cannot be written (no permission)")
    return p


NAME_MAX = 255  # bytes in one name on the usual file systems
TMP_EXTRA = 14  # bytes atomic_write's temporary file adds to a file's name: "." and ".xxxxxxxx.tmp"


def _named(path: str | os.PathLike, what: str, limit: int = NAME_MAX) -> Path:
    """A path that names something: not empty, its last part at most ``limit`` bytes long."""
    if str(path) == "":
        raise OptionError(f"{what}: give a name, not an empty one")
    p = Path(path)
    if len(os.fsencode(p.name)) > limit:
        raise OptionError(f"{what}: the name {p.name[:40]!r}... is longer than {limit} bytes")
    return p


def _check_parent(p: Path, what: str) -> None:
    """The folder a file or folder is to be made in exists (and is a folder)."""
    if p.parent.exists() and not p.parent.is_dir():
        raise OptionError(f"{what}: {str(p.parent)!r} in {str(p)!r} is a file, not a folder")
    if not p.parent.is_dir():
        raise OptionError(f"{what}: the folder {str(p.parent)!r} of {str(p)!r} does not exist")


def _can_create_in(folder: Path) -> bool:
    """Can a file be made in this folder? Tried for real (permissions, read-only or special
    file systems: os.access says yes to root where a write would fail)."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".voiopt-check.", dir=folder)
    except OSError:
        return False
    os.close(fd)
    os.unlink(tmp)
    return True


def check_output_dir(path: str | os.PathLike, what: str = "-o/--output", parents: bool = False) -> Path:
    """Before any work: the folder exists and is writable, or can be made in a writable parent
    (with ``parents``, in the nearest folder that exists, its missing parents made too)."""
    p = _named(path, what)
    if p.exists() and not p.is_dir():
        raise OptionError(f"{what}: {str(p)!r} is a file, not a folder")
    if p.is_dir():
        if not _can_create_in(p):
            raise OptionError(f"{what}: the folder {str(p)!r} cannot be written (no permission)")
        return p
    if parents:
        up = p.parent
        while not up.exists() and up != up.parent:
            up = up.parent
        check_output_dir(up, what)  # the nearest folder that exists: the rest is made in it
        return p
    _check_parent(p, what)
    if not _can_create_in(p.parent):
        raise OptionError(f"{what}: the folder {str(p)!r} cannot be made in {str(p.parent)!r} (no permission)")
    return p
