"""How the command ends when its surroundings go: voiopt's own warnings as one line on stderr,
and a closed stdout (``voiopt generate | head -1``) as silence and exit status 0."""

from __future__ import annotations

import os
import sys
import warnings

from rich.console import Console

from voiopt.errors import InstanceWarning

err = Console(stderr=True, highlight=False, soft_wrap=True)


def one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """voiopt's own warnings as one line on stderr; others as Python shows them."""
    if issubclass(category, InstanceWarning):
        err.print(f"voiopt: warning: {message}", markup=False)
    else:
        _python_warning(message, category, filename, lineno, file, line)


_python_warning = warnings.showwarning


def pipe_closed() -> int:
    """Python's recipe for a closed stdout: point it at devnull (the flush at exit would fail
    again) and exit 0, saying nothing."""
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return 0
