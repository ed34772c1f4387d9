"""A fast planner: beam search over dp's labels (``--method beam``).

The forward pass of the label-setting programme (voiopt/solvers/dp/solver.py) keeps at most ``width``
labels per lattice point and slot, those with the best admissible bounds, and so is a
heuristic; the widths grow (2, 4, 8, ... 64) while the work allows, each pass pruning with the
best plan so far. It returns the best plan and no bound: dp and the MILP prove. Where dp is fast
(the paper's setting) it is dp's own first incumbent; beyond, it gives plans in seconds where
the exact search gives none.

The default schedule is bounded by work, not by the clock, so that the plan depends on the
instance alone: a pass of twice the width makes about twice the labels, and the next width runs
only if the labels made so far and twice the last pass's stay within LABEL_BUDGET. On the
paper's networks every width to 64 fits; on a 26-sensor factory floor only width 2 does
(41,812 labels; width 64 took 77 s there). ``max_width`` runs every width up to it, whatever
the work.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from voiopt import objectives
from voiopt.core.instance import Instance
from voiopt.core.plan import Plan
from voiopt.core.result import Result
from voiopt.core.simulate import simulate
from voiopt.errors import OptionError
from voiopt.runtime.progress import progress_bar
from voiopt.runtime.status import Status
from voiopt.runtime.stop import Stopped, watch
from voiopt.solvers import options
from voiopt.solvers.base import DEFAULT_MEMORY_GB, check_limits, idle_plan, require_memory
from voiopt.solvers.dp import solver as dp
from voiopt.solvers.labels.search import search
from voiopt.solvers.labels.tables import build_tables, table_bytes

WIDTHS = (2, 4, 8, 16, 32, 64)
LABEL_BUDGET = 100_000  # labels of the default schedule's passes; a pass costs about 70 us a label


@dataclass(frozen=True)
class Options(options.Options):
    """beam's options (``solve``'s keywords)."""

    max_width: int | None = None

def solve(instance: Instance, objective: str, *, progress: bool = False, time_limit: float | None = None,
          memory_limit: float = DEFAULT_MEMORY_GB, max_width: int | None = None) -> Result:
    """Best plan of beam passes of growing width: by default 2, 4, ..., 64 while the labels stay
    within LABEL_BUDGET; with ``max_width``, every width up to it (or the time limit)."""
    objective = objectives.get(objective)
    check_limits(time_limit, memory_limit)
    if max_width is not None and (isinstance(max_width, bool) or not isinstance(max_width, int) or max_width < 1):
        raise OptionError(f"max_width: must be an integer >= 1, got {max_width!r}")
    budget = LABEL_BUDGET if max_width is None else None
    max_width = WIDTHS[-1] if max_width is None else max_width
    require_memory(table_bytes(instance), memory_limit, "the beam's tables")
    startup_s = dp.warm_up()
    widths = [w for w in WIDTHS if w < max_width] + [max_width]
    with watch(time_limit, memory_limit) as stop:
        try:
            tab = build_tables(instance, objective, stop)
        except Stopped:  # no pass: the plan below
            tab, widths = None, []
        best_plan, best_internal, passes = None, -np.inf, []
        with progress_bar(progress) as bar:
            task = bar.add_task("beam widths", total=len(widths))
            for w in widths:
                out = search(tab, best_internal, beam=w, tdma=False, stop=stop)
                if out.plan is not None:
                    plan = Plan.from_indices(instance, *out.plan)
                    v = tab.internal(simulate(instance, plan).metrics[objective])
                    if best_plan is None or v > best_internal:
                        best_plan, best_internal = plan, v
                passes.append({"width": w, "labels": out.labels, "complete": out.complete,
                               "value": None if best_plan is None else tab.external(best_internal)})
                bar.update(task, advance=1, description=f"beam width {w}")
                if stop.check() is not None:
                    break
                made = sum(p["labels"] for p in passes)
                if budget is not None and made + 2 * out.labels > budget:  # the next, about twice this one, would pass it
                    bar.update(task, total=len(passes))
                    break
        if best_plan is None:  # stopped before any pass finished
            best_plan = idle_plan(instance)
    solver = {"passes": passes, "max_width": max_width, "label_budget": budget, "startup_s": startup_s}
    if stop.reason:
        solver["stopped"] = stop.describe()
    return Result.from_plan(instance, "beam", objective, best_plan, status=stop.reason or Status.FEASIBLE,
                            runtime_s=stop.elapsed(), solver=solver)
