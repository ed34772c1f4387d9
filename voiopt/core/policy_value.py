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
from voiopt.runtime.stop import Stop, halt_if_asked

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
