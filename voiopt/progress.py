"""Progress bars: rich on stderr, shown only where asked."""

from __future__ import annotations

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn


def progress_bar(enabled: bool, *extra_columns) -> Progress:
    """A rich progress bar on stderr; disabled (no output) when ``enabled`` is false. Not on a
    terminal (a log file, a pipe), the line is not cut to 80 columns: it is written once, at
    the end, and cut it lost the counts ('1000000/1…')."""
    console = Console(stderr=True)  # stdout stays for results (--json)
    if not console.is_terminal:
        console = Console(stderr=True, width=200)
    return Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        *extra_columns,
        TimeElapsedColumn(),
        disable=not enabled,
        transient=False,
        console=console,
    )
