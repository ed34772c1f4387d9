"""The viewer's one self-contained HTML file: page.html with page.css, page.js and the story's
JSON inlined. It loads nothing from the network (no external src, href or @import), so it
opens from an e-mail attachment; docs/viewer.md documents the page and its JS API."""

from __future__ import annotations

import json
import os
from importlib import resources
from typing import Any

from voiopt.runtime.files import atomic_write


def _asset(name: str) -> str:
    return resources.files("voiopt.viewer").joinpath(name).read_text(encoding="utf-8")


def _escape_html(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def render(data: dict[str, Any]) -> str:
    """The page of a story (``voiopt.viewer.story.story``) as one HTML string. The JSON is
    written with every float's shortest round-trip repr (so the page's numbers are the
    simulator's to the last bit); "</" is escaped so that no string ends the script early."""
    payload = json.dumps(data, separators=(",", ":"), allow_nan=False, ensure_ascii=True).replace("</", "<\\/")
    title = _escape_html(f"voiopt show: {data['instance']['name']}")
    parts = {"__TITLE__": title, "__STYLE__": _asset("page.css"), "__SCRIPT__": _asset("page.js"), "__DATA__": payload}
    page = _asset("page.html")
    for key in ("__TITLE__", "__STYLE__", "__SCRIPT__"):  # the data last: it may hold any text
        page = page.replace(key, parts[key], 1)
    return page.replace("__DATA__", payload, 1)


def write(data: dict[str, Any], path: str | os.PathLike) -> None:
    """Write the page atomically (a failure names the path)."""
    text = render(data)
    try:
        with atomic_write(path) as f:
            f.write(text)
    except OSError as e:
        raise OSError(f"{os.fsdecode(path)}: cannot write: {e.strerror or e}") from None
