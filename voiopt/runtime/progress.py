"""Progress bars: rich on stderr, shown only where asked."""

from __future__ import annotations

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Column
from rich.text import Text


def text_column(template: str) -> TextColumn:
    """A column of text that does not wrap: where a line is too long, the bar gives way first,
    down to one column (on an 80-column terminal Q-learning's line was cut to 'qlearning ━━━
    1000000/1…'); only a line wider than the terminal without its bar is still cut."""
    return TextColumn(template, table_column=Column(no_wrap=True))


class _Counts(MofNCompleteColumn):
    """done/total; nothing where the total is unknown (dp's subsets showed '0/?' throughout)."""

    def render(self, task):
        return Text("") if task.total is None else super().render(task)


def progress_bar(enabled: bool, *extra_columns) -> Progress:
    """A rich progress bar on stderr; disabled (no output) when ``enabled`` is false. Not on a
    terminal (a log file, a pipe), the line is not cut to 80 columns: it is written once, at
    the end, and cut it lost the counts ('1000000/1…')."""
    console = Console(stderr=True)  # stdout stays for results (--json)
    if not console.is_terminal:
        console = Console(stderr=True, width=200)
    return Progress(
        text_column("[bold]{task.description}"),
        BarColumn(table_column=Column(min_width=1)),
        _Counts(table_column=Column(no_wrap=True)),
        *extra_columns,
        TimeElapsedColumn(table_column=Column(no_wrap=True)),
        disable=not enabled,
        transient=False,
        console=console,
    )
