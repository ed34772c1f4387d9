"""Ctrl-C as a stop request: long solves check ``stop.requested`` and return their best plan."""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn


class StopFlag:
    def __init__(self) -> None:
        self.requested = False
        self.reason: str | None = None

    def request(self, reason: str = "interrupted") -> None:
        self.requested = True
        self.reason = reason


@contextmanager
def stop_on_interrupt():
    """Within the block, the first Ctrl-C sets the flag (the second one raises as usual).

    Outside the main thread (worker pools) signals cannot be caught; the flag then just
    never fires."""
    flag = StopFlag()
    if threading.current_thread() is not threading.main_thread():
        yield flag
        return
    previous = signal.getsignal(signal.SIGINT)

    def handler(signum, frame):
        if flag.requested:
            signal.signal(signal.SIGINT, previous)
            raise KeyboardInterrupt
        flag.request("interrupted")

    signal.signal(signal.SIGINT, handler)
    try:
        yield flag
    finally:
        signal.signal(signal.SIGINT, previous)


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
    )
