"""The value of a policy under lossy links (MODEL.md section 11), for the averaged objectives.

- Exact, by forward enumeration: the distribution over observed states, slot by slot, under
  the policy's actions and each upload's two outcomes; the expected reward of every slot is
  summed. Exact wherever the states of every slot stay below ``max_states``.
- Otherwise Monte Carlo over coupled scenarios (voiopt.core.scenarios: the same U(t, i) for
  every policy given the same seed): each scenario's run is the lossless plan it realises
  (failed uploads as none), valued by the simulator; the mean with its 95 % Student-t CI
  and the number of scenarios.
"""

from __future__ import annotations

import numpy as np

from voiopt import objectives
from voiopt.core.plan import Plan
from voiopt.core.policy import Policy
from voiopt.core.result import Evaluation
from voiopt.core.scenarios import Estimate, monte_carlo, sample_scenarios
from voiopt.errors import OptionError
from voiopt.runtime.stop import Stop, Stopped, halt_if_asked, watch

MAX_STATES = 200_000  # states of one slot past which a policy's value is estimated instead
DEFAULT_SAMPLES = 1000
AVERAGED = tuple(name for name, o in objectives.BY_NAME.items() if o.per_slot)  # the averaged objectives


def _reward(policy: Policy, objective: str, state: tuple) -> float:
    if not objectives.get(objective).voi:
        return -float(max(state[2]))
    return policy.steps.reward(state[2], state[3])


def _act(policy: Policy, t: int, state: tuple):
    """The policy's upload in slot t and state, and its legal move (the steps' form); an illegal
    action is refused in one line."""
    u, m = policy.choose(t, state)
    move = policy.steps.legal(t, state, u, m)
    if move is None:
        raise OptionError(f"policy: its action ({u}, {m}) at slot {t} is illegal in state {state}")
    return u, move


STOP_EVERY = 256  # states between two looks at the stop rule


def exact_value(policy: Policy, objective: str | None = None, max_states: int = MAX_STATES,
                stop: Stop | None = None) -> float | None:
    """The policy's exact expected ``objective`` (default its own), or None where some slot has
    more than ``max_states`` reachable states. ``stop`` (the stop rule) is looked at every
    STOP_EVERY states: once it says stop, voiopt.runtime.stop.Stopped."""
    objective = objective or policy.objective
    if objective not in AVERAGED:
        raise OptionError(f"objective: a policy's value is computed for {', '.join(AVERAGED)}, got {objective!r}")
    steps = policy.steps
    layer = {steps.start_state(): 1.0}
    total = 0.0
    for t in range(steps.T):
        nxt: dict = {}
        for k, (state, prob) in enumerate(layer.items()):
            if k % STOP_EVERY == 0:
                halt_if_asked(stop)
            u, move = _act(policy, t, state)
            for p2, s2 in steps.outcomes(t, state, u, *move):
                nxt[s2] = nxt.get(s2, 0.0) + prob * p2
        if len(nxt) > max_states:
            return None
        total += sum(prob * _reward(policy, objective, s) for s, prob in nxt.items())
        layer = nxt
    mean = total / steps.T
    return mean if objectives.get(objective).maximise else -mean


def trace(policy: Policy, u_row: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The policy's run in scenario ``u_row`` ((T, N) uniforms): its points, the uploads it
    scheduled (-1: none) and whether each succeeded (U(t, i) < p_i(d))."""
    steps = policy.steps
    state = steps.start_state()
    idx, sched, ok = [], [], []
    for t in range(steps.T):
        u, move = _act(policy, t, state)
        success = steps.succeeded(t, state, u, float(u_row[t, u])) if u >= 0 else False
        idx.append(state[0])
        sched.append(u)
        ok.append(success)
        state = steps.after(t, state, u, *move, success)
    return np.array(idx), np.array(sched), np.array(ok, dtype=bool)


def run(policy: Policy, u_row: np.ndarray) -> Plan:
    """The lossless plan that the policy realises in scenario ``u_row``: its positions, and its
    uploads where they succeed."""
    idx, sched, ok = trace(policy, u_row)
    return Plan.from_indices(policy.instance, idx, np.where(ok, sched, -1))


def monte_carlo_value(policy: Policy, scenarios: np.ndarray, objective: str | None = None,
                      stop: Stop | None = None) -> Estimate:
    """The mean of ``objective`` over the policy's runs in the given scenarios, with its CI
    (with ``stop``: over those done before it said stop, as core.scenarios.monte_carlo)."""
    return monte_carlo(policy.instance, lambda u: run(policy, u), scenarios, objective or policy.objective, stop=stop)


def evaluate_policy(policy: Policy, objective: str | None = None, *, samples: int = DEFAULT_SAMPLES, seed: int = 0,
                    max_states: int = MAX_STATES) -> dict:
    """The fields a result states for a policy's value: ``value`` and ``evaluation`` ("exact"),
    or those with ``samples``, ``value_ci`` and ``seed`` ("monte-carlo")."""
    objective = objective or policy.objective
    value = exact_value(policy, objective, max_states)
    if value is not None:
        return {"value": value, "evaluation": Evaluation.EXACT, "samples": None, "value_ci": None}
    est = monte_carlo_value(policy, sample_scenarios(policy.instance, samples, seed), objective)
    return {"value": est.mean, "evaluation": Evaluation.MONTE_CARLO, "samples": est.count, "value_ci": list(est.ci),
            "scenario_seed": seed}


GRACE_S = 0.3  # what a step after a stop still gets: a Monte Carlo value needs a few scenarios
MIN_SCENARIOS = 2  # a CI needs two; they take milliseconds, and are run whatever the stop rule says


def follow_on(stop: Stop, share: float = 1.0) -> float | None:
    """The time limit of a step after the main work (None: none): ``share`` of what is left of
    the run's limit, at least GRACE_S; GRACE_S once the rule has said stop. A Ctrl-C reaches
    every step's own watch, and one that came before it opens stopped."""
    if stop.check() is not None:
        return GRACE_S
    left = stop.remaining()
    return None if left is None else max(left * share, GRACE_S)


def _why(step: Stop, stop: Stop) -> str:
    """Why a step stopped: the run's own limit (a step's grace is no limit of the user's)."""
    return stop.describe() if stop.check() else step.describe()


def _within(stop: Stop, policy: Policy, run, otherwise, share: float = 1.0):
    """(run(rule), rule) under a follow-on stop rule, or (otherwise(), rule) where the rule
    stopped it; the rule's reason says why. A policy that decides by solving (it has a
    ``stop`` attribute: re-planning, a function) asks the same rule between its solves."""
    with watch(follow_on(stop, share), stop.memory_limit) as rule:
        asks = hasattr(policy, "stop")
        before = policy.stop if asks else None
        if asks:
            policy.stop = rule
        try:
            return run(rule), rule
        except Stopped:
            return otherwise(), rule
        finally:
            if asks:
                policy.stop = before


def value_under(stop: Stop, policy: Policy, objective: str, samples: int, seed: int, max_states: int = MAX_STATES,
                exact_share: float = 1.0) -> tuple[dict, str | None, str | None]:
    """The policy's value under the run's stop rule: the evaluation fields (as
    ``evaluate_policy``), the reason that cut its Monte Carlo short (None: not cut) and a note
    on why it is not exact. Exact where its states (at most ``max_states`` a slot) can be
    enumerated within ``exact_share`` of the time left; else Monte Carlo over the coupled
    scenarios done before the rule said stop (at least MIN_SCENARIOS), with their count."""
    value, exact = _within(stop, policy, lambda rule: exact_value(policy, objective, max_states, stop=rule),
                           lambda: None, exact_share)
    if value is not None:
        return {"value": value, "evaluation": Evaluation.EXACT, "samples": None, "value_ci": None}, None, None
    scenarios = sample_scenarios(policy.instance, samples, seed)
    est, mc = _within(stop, policy, lambda rule: monte_carlo_value(policy, scenarios, objective, stop=rule),
                      lambda: monte_carlo_value(policy, scenarios[:MIN_SCENARIOS], objective))
    why = (f"exact enumeration stopped ({_why(exact, stop)})" if exact.reason
           else f"more than {max_states:,} states in a slot")
    note = f"valued by Monte Carlo over {est.count} of {samples} scenarios: {why}" + (
        f"; Monte Carlo stopped ({_why(mc, stop)})" if mc.reason else "")
    evaluation = {"value": est.mean, "evaluation": Evaluation.MONTE_CARLO, "samples": est.count,
                  "value_ci": list(est.ci), "scenario_seed": seed}
    return evaluation, mc.reason, note
