"""``--method policy-dp``: the exact optimal policy of one robot under lossy links (MODEL.md
section 11) for the two averaged objectives, by the layered expectimax of ``layered.py`` (the
plain one of ``expectimax.py`` where the states do not pack into a key).

The lossless optimum (dp on the instance without its links) comes first: it bounds every
policy (a failed upload acts as an unscheduled slot), and its plan, as an open-loop policy, is
the answer kept if the expectimax cannot finish. The expectimax then values every state
reachable from the start; the optimal policy is the table of its actions over the states it
reaches, and its value is computed again from that table by forward enumeration
(voiopt.core.policy_value), not read from the programme. On a time or memory limit or Ctrl-C
it returns the open-loop plan with its exact expected value, the lossless bound, and the
stop's reason as the status.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from voiopt import objectives
from voiopt.core.expectation import expected_metrics
from voiopt.core.instance import Instance
from voiopt.core.links import without_links
from voiopt.core.policy import Policy, table_of
from voiopt.core.policy_value import exact_value
from voiopt.core.result import BoundKind
from voiopt.errors import OptionError
from voiopt.runtime.progress import progress_bar
from voiopt.runtime.status import Status
from voiopt.runtime.stop import Stopped, watch
from voiopt.solvers import options
from voiopt.solvers.base import DEFAULT_MEMORY_GB, check_limits
from voiopt.solvers.policy import layered
from voiopt.solvers.policy.expectimax import AVERAGED
from voiopt.solvers.policy.report import policy_result

LOSSLESS_SHARE = 0.25  # of a time limit, the most the lossless dp may take


def check_averaged(objective: str, method: str) -> None:
    objectives.get(objective)
    if objective not in AVERAGED:
        raise OptionError(f"objective: {method} takes {' or '.join(AVERAGED)}, not {objective!r} (a bottleneck "
                          "objective's optimal policy needs the running extreme in its state, MODEL.md 11; not built)")


def lossless_optimum(instance: Instance, objective: str, time_limit: float | None, memory_limit: float):
    """dp's result on the instance without links: its plan and its proven bound."""
    from voiopt.solvers.dp import solver as dp

    return dp.solve(without_links(instance), objective, time_limit=time_limit, memory_limit=memory_limit)


@dataclass(frozen=True)
class Options(options.Options):
    """policy-dp's options: the common ones (progress, time and memory limits)."""


def solve(instance: Instance, objective: str, *, progress: bool = False, time_limit: float | None = None,
          memory_limit: float = DEFAULT_MEMORY_GB):
    """The optimal policy and its exact value, status ``optimal``; stopped early, the lossless
    optimum plan as an open-loop policy, its exact value and the lossless bound."""
    check_averaged(objective, "policy-dp")
    check_limits(time_limit, memory_limit)
    layered.warm_up()
    t0 = time.perf_counter()
    share = None if time_limit is None else time_limit * LOSSLESS_SHARE
    base = lossless_optimum(instance, objective, share, memory_limit)
    lossless_bound = base.bound
    open_loop = Policy(instance, objective, "policy-dp", plan=base.plan)
    left = None if time_limit is None else max(1e-3, time_limit - (time.perf_counter() - t0))
    solver = {"lossless": {"status": base.status, "value": base.value, "bound": base.bound}}
    with watch(left, memory_limit) as stop, progress_bar(progress) as bar:
        task = bar.add_task("policy-dp: states", total=None)
        search = layered.exact_search(instance, objective, stop=stop, tick=lambda n: bar.update(task, completed=n))
        try:
            value = search.solve()
            rows = search.on_policy()
        except Stopped:
            value = None
        bar.update(task, completed=search.states)
    solver["states"] = search.states
    solver["search"] = "layered" if isinstance(search, layered.Layered) else "plain (the states do not pack into a key)"
    if value is None:
        solver["stopped"] = (f"time limit of {time_limit:g} s reached" if stop.reason == Status.TIME_LIMIT
                             and time_limit is not None else stop.describe())
        solver["note"] = "the expectimax did not finish: the policy is the lossless optimum plan, open-loop"
        evaluation = {"value": expected_metrics(instance, base.plan)[objective], "evaluation": "exact"}
        return policy_result(instance, "policy-dp", objective, open_loop, evaluation, status=stop.reason,
                             bound=lossless_bound, bound_kind=BoundKind.LOSSLESS, runtime_s=time.perf_counter() - t0,
                             solver=solver)
    policy = table_of(rows, objective, instance, "policy-dp")
    checked = exact_value(policy, objective, max_states=len(rows) + 1)
    solver["programme_value"] = value
    solver["policy_states"] = len(rows)
    return policy_result(instance, "policy-dp", objective, policy, {"value": checked, "evaluation": "exact"},
                         status=Status.OPTIMAL, bound=value, bound_kind=BoundKind.EXACT, runtime_s=time.perf_counter() - t0,
                         solver=solver)
