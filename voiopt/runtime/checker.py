"""The checker behind instance validation: it collects every violated rule with its field
path, and shows offending values briefly (``show``), however large or deep they are."""

from __future__ import annotations

import json
import math
import re
from typing import Any

MAX_ERRORS = 20  # violations kept in all_errors; the rest are counted


class Checker:
    """Collects every violated rule, so one run reports them all (the first is raised).
    At most MAX_ERRORS messages are kept; the rest are only counted."""

    def __init__(self) -> None:
        self.errors: list[str] = []
        self.dropped = 0

    def fail(self, path: str, message: str) -> None:
        """Record a violated rule (returns None, the value of a field that failed)."""
        if len(self.errors) < MAX_ERRORS:
            self.errors.append(f"{path}: {message}")
        else:
            self.dropped += 1

    def obj(self, value: Any, path: str, allowed: set[str] | frozenset[str], required: Any) -> dict | None:
        if not isinstance(value, dict):
            self.fail(path or "instance", f"must be an object, got {show(value)}")
            return None
        for key in value:
            if key not in allowed:
                self.fail(join_path(path, key), f"unknown field (allowed: {', '.join(sorted(allowed))})")
        for key in sorted(required):
            if key not in value:
                self.fail(join_path(path, key), "is required")
        return value

    def number(self, d: dict, key: str, path: str, default: float | None = None, *, positive: bool = False,
               nonnegative: bool = False, open01: bool = False, within: tuple[float, float, str] | None = None,
               at_most: tuple[float, str] | None = None) -> float | None:
        if key not in d:
            return default
        v = d[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            return self.fail(join_path(path, key), f"must be a number, got {show(v)}")
        f = _to_float(v)
        if not math.isfinite(f):
            rule = "must be finite"
        elif positive and not f > 0:
            rule = "must be > 0"
        elif nonnegative and not f >= 0:
            rule = "must be >= 0"
        elif open01 and not 0 < f < 1:
            rule = "must be in (0, 1)"
        elif within is not None and not within[0] <= f <= within[1]:
            rule = f"must be in [{within[0]:g}, {within[1]:g}]{within[2]}"
        elif at_most is not None and not f <= at_most[0]:
            rule = f"must be <= {at_most[0]:g}{at_most[1]}"
        else:
            return f
        return self.fail(join_path(path, key), f"{rule}, got {show(v)}")

    def integer(self, d: dict, key: str, path: str, default: int | None, minimum: int,
                maximum: tuple[int, str] | None = None) -> int | None:
        v = d.get(key, default)
        if key not in d:
            return v
        n = int(v) if isinstance(v, float) and math.isfinite(v) and v.is_integer() else v
        if isinstance(n, bool) or not isinstance(n, int):
            return self.fail(join_path(path, key), f"must be an integer, got {show(v)}")
        if n < minimum:
            return self.fail(join_path(path, key), f"must be an integer >= {minimum}, got {show(v)}")
        if maximum is not None and n > maximum[0]:
            return self.fail(join_path(path, key), f"must be an integer <= {maximum[0]}{maximum[1]}, got {show(v)}")
        return int(n)

    def point(self, d: dict, key: str, path: str, where: str | None = None) -> tuple[float, float] | None:
        """A pair of finite numbers; ``where`` names it in messages (default path.key)."""
        v = d.get(key)
        where = where or join_path(path, key)
        if not isinstance(v, (list, tuple)) or len(v) != 2:
            self.fail(where, f"must be a pair [x, y], got {show(v)}")
            return None
        x, y = v
        for j, c in enumerate(v):
            if isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(_to_float(c)):
                self.fail(f"{where}[{j}]", f"must be a finite number, got {show(c)}")
                return None
        return (float(x), float(y))


def _to_float(v: int | float) -> float:
    """float(v), or +-inf for an integer beyond the float range (float() would raise)."""
    try:
        return float(v)
    except OverflowError:
        return math.inf if v > 0 else -math.inf


_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def join_path(path: str, key: Any) -> str:
    """``path.key``; a key that is not a plain name (a hostile file's "a\\nb") is quoted, so a
    message stays one short line."""
    if not (isinstance(key, str) and _IDENTIFIER.fullmatch(key) and len(key) <= 40):
        key = show(key, 40)
    return f"{path}.{key}" if path else key


def show(v: Any, limit: int = 60) -> str:
    """A value as it appears in a message: JSON-like, at most ``limit`` characters, cheap for
    huge or deeply nested values (it stops rendering once the text is long enough)."""
    parts, size = [], 0
    for token in _tokens(v, limit):
        parts.append(token)
        size += len(token)
        if size > limit:
            break
    text = "".join(parts)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _show_int(v: int) -> str:
    sign = "a negative" if v < 0 else "an"
    digits = getattr(v, "digits", None)  # _files.HugeInt: a literal of over 1000 digits
    if digits is not None:
        return f"{sign} integer of {digits} digits"
    if abs(v) < 10**60:
        return str(v)
    if v.bit_length() < 13000:  # str() refuses more than 4300 digits
        return f"{sign} integer of {len(str(abs(v)))} digits"
    return f"{sign} integer of about {int(v.bit_length() * math.log10(2)) + 1} digits"


def _tokens(v: Any, limit: int):
    if v is None:
        yield "null"
    elif isinstance(v, bool):
        yield "true" if v else "false"
    elif isinstance(v, int):
        yield _show_int(v)
    elif isinstance(v, float):
        yield "NaN" if math.isnan(v) else ("Infinity" if v > 0 else "-Infinity") if math.isinf(v) else repr(float(v))
    elif isinstance(v, str):
        yield json.dumps(v[: limit + 1])
    elif isinstance(v, (list, tuple, dict)):
        items = v.items() if isinstance(v, dict) else enumerate(v)
        yield "{" if isinstance(v, dict) else "["
        for n, (k, x) in enumerate(items):
            if n:
                yield ", "
            if isinstance(v, dict):
                yield from _tokens(k, limit)
                yield ": "
            yield from _tokens(x, limit)
        yield "}" if isinstance(v, dict) else "]"
    else:
        yield repr(v)[: limit + 1]
