"""Progress bars: rich on stderr, shown only where asked."""

from __future__ import annotations

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn


def progress_bar(enabled: bool, *extra_columns) -> Progress:
    """A rich progress bar on stderr; disabled (no output) when ``enabled`` is false."""
    return Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        *extra_columns,
        TimeElapsedColumn(),
        disable=not enabled,
        transient=False,
        console=Console(stderr=True),  # stdout stays for results (--json)
    )
