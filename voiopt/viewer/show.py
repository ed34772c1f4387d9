"""``voiopt show RESULT... [-o plan.html]``: results or plans on one instance, one page."""

from __future__ import annotations

import os
from pathlib import Path

from voiopt.core.instance import Instance, show
from voiopt.errors import OptionError
from voiopt.viewer import page
from voiopt.viewer.story import Entry, read_entry, story


def default_output(first: str | os.PathLike) -> Path:
    """plan.html for plan.json: the first file's name with .html, in the current folder."""
    return Path(Path(first).stem + ".html")


def gather(paths: list[str], instance_path: str | None = None) -> tuple[Instance, list[Entry], str]:
    """The instance and an Entry per file. Every file must be for one instance: results on
    different instances are refused (one line naming both), as is a plan that names none
    when no --instance is given."""
    from voiopt.experiments.plots import instance_for

    entries, names = [], []
    for p in paths:
        entry, name = read_entry(p)
        entries.append(entry)
        names.append((p, name))
    named = [(p, n) for p, n in names if n is not None]
    for p, n in named[1:]:
        if n != named[0][1]:
            raise OptionError(f"RESULT: {p} is for instance {show(n)}, {named[0][0]} for {show(named[0][1])}: "
                              "voiopt show puts plans of one instance side by side")
    first, name = named[0] if named else (paths[0], None)
    instance, where = instance_for(name, instance_path, first, "result")
    return instance, entries, where


def run(paths: list[str], output: str | os.PathLike, instance_path: str | None = None, seed: int = 0) -> Path:
    """Write the page of ``paths`` to ``output``; return the path written."""
    instance, entries, where = gather(paths, instance_path)
    page.write(story(instance, entries, where, seed), output)
    return Path(output)
