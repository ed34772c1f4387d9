"""Progress bars as a person reads them (voiopt/runtime/progress.py)."""

from __future__ import annotations

import io

from rich.console import Console

from voiopt.runtime.progress import progress_bar, text_column


def shown(bar, width: int) -> str:
    console = Console(width=width, file=io.StringIO(), color_system=None, force_terminal=True)
    console.print(bar.get_renderable())
    return console.file.getvalue()


def test_a_task_of_unknown_length_shows_no_count():
    """dp's subsets have no total: the line read '0/?' throughout."""
    bar = progress_bar(True)
    bar.add_task("dp subset of 5 sensors  best 1138.27  bound 1207.05  gap 5.7 %", total=None)
    line = shown(bar, 100)
    assert "dp subset of 5 sensors  best 1138.27  bound 1207.05  gap 5.7 %" in line and "?" not in line


def test_at_80_columns_the_bar_gives_way_and_no_text_is_cut():
    """Q-learning's line at the paper's 10^6 episodes, every field at its widest."""
    bar = progress_bar(True, text_column("eps {task.fields[eps]:.3f}"), text_column("greedy {task.fields[greedy]}"),
                       text_column("states {task.fields[states]}"))
    task = bar.add_task("qlearning", total=1_000_000, eps=0.25, greedy="1.07226e+06", states=2_874_741)
    bar.update(task, completed=313_037)
    line = shown(bar, 80).rstrip("\n")
    assert len(line) <= 80 and "…" not in line, line
    assert "313037/1000000 eps 0.250 greedy 1.07226e+06 states 2874741 0:00:00" in line
