"""What ``bench export`` writes beside VoI-Lib's instances, as CVRPLIB and QOBLIB publish
theirs: a README (the certified values, the formats, how to score) and one solution file per
instance and objective, in the submission format ``bench score`` reads back."""

from __future__ import annotations

from typing import Any

from voiopt.objectives import OBJECTIVES
from voiopt.voilib.certificates import provenance

CHECK_CODES = {0: "valid: the plan is legal and any value it states is what it gives",
               2: "bad input otherwise: an unknown instance or objective, a misspelt field",
               3: "illegal plan: it breaks a rule of the instance (MODEL.md section 3)",
               4: "wrong claimed value: the stated value is not what the plan gives (relative 1e-9)",
               5: "unreadable file: missing, a folder, not UTF-8, not JSON, or over the size limit"}


COLUMNS = ("name", "N", "T", "area", "rules", "links", *OBJECTIVES)  # the table of bench list and the README


def solution_name(name: str, objective: str) -> str:
    """The solution file of an instance and objective, under ``solutions/``."""
    return f"{name}__{objective}.json"


def solution(name: str, objective: str, sha256: str, cert: dict[str, Any]) -> dict[str, Any]:
    """A certificate's plan as a submission: ``voiopt bench score`` and ``bench check`` read it."""
    return {"instance": name, "instance_sha256": sha256, "objective": objective, "plan": cert["plan"],
            "value": cert.get("plan_value", cert["value"]),  # lossy: the plan's exact expectation, not the policy's
            "certificate": {"status": cert["status"], "bound": cert["bound"], "provenance": provenance(cert)}}


def markdown(rows: list[dict[str, Any]]) -> list[str]:
    """The table of ``table_rows`` in Markdown, a line each."""
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    return lines + ["| " + " | ".join(str(r[c]) for c in COLUMNS) + " |" for r in rows]


def readme(version: str, rows: list[dict[str, Any]]) -> str:
    """The README of an exported VoI-Lib: the table of certified values (``table_rows``), the
    files, and how to score a plan."""
    table = markdown(rows)
    codes = "\n".join(f"| {k} | {v} |" for k, v in CHECK_CODES.items())
    return f"""# VoI-Lib {version}

Benchmark instances for planning a mobile robot's path and upload schedule that collects status
updates from sensors, maximising value of information (VoI) or minimising age of information
(AoI). Written by `voiopt bench export`; the model is voiopt's MODEL.md. Each certificate gives
the optimum of an objective (one number), or `[lower, upper]` where the optimum is still open.

## Certified values

{chr(10).join(table)}

`min-voi` and `mean-min-voi` are maximised; `max-aoi` and `mean-max-aoi` are minimised.

## The lossy set

Instances with `links` (MODEL.md section 11: an upload may fail; `links` is `bernoulli:P` or
`rayleigh:SNR_DB` as `voiopt generate --links` spells them) have lossy certificates. Every
objective is an expectation over the upload outcomes, and each certificate says what its numbers
are; its cell in the table names the kind of its bound:

- `(exact)`: `optimal`; the optimal policy's exact value (dynamic programming over the
  reachable observed states, the policy's table valued again by forward enumeration);
- `(lossless)`: `bounded`; `value` is the best known plan's exact expected value (`value_of`
  `plan`) and `bound` the lossless optimum, which bounds every policy (proven).

`bound` is always proven. Where computed, an `information-relaxation` bound is stored beside it
(`information_relaxation`: its one-sided 95 % confidence limit, samples and confidence):
statistical, never the certificate's bound. `plan_value` is the certificate's plan's exact
expected value (against `value`, the value of adaptivity where `value_of` is `policy`);
`lossless_bound` the lossless optimum. An optimal policy is in `policy_file` (under `policies/`,
with its `policy_sha256`; `voiopt.Policy.load` reads it). The solution file holds the best plan
with its `plan_value`.

On a lossy instance `bench score` values a plan by its exact expectation, and a policy (the
result's `solver.policy_file`, saved beside it by `voiopt solve`) exactly where its states can
be enumerated, else by Monte Carlo on the library's fixed scenarios, with the 95 % CI and the
number of scenarios (`evaluation`, `value_ci`, `samples` in `--json`).

## Files

- `NAME.json`: an instance (MODEL.md section 1). Its identity is the sha256 of its canonical
  JSON: Python's `json.dumps(d, sort_keys=True, separators=(",", ":"))`.
- `certificates.json`: per instance its `sha256`, and per objective the certificate: `status`
  (`optimal`, or `bounded`: the optimum lies between `value` and `bound`), `value` (the
  simulated value of `plan`; on the lossy set, as above), `bound` (proven), `plan`, `method` and `bound_method`, each
  certifying method's own result in `checks`, and `provenance`: `proved_by` (method,
  voiopt version, UTC date; `null` where the date was not recorded), `found_by` and
  `confirmed_by` (the other methods that proved the same optimum independently).
- `solutions/NAME__OBJECTIVE.json`: the certificate's plan as a submission (below), with its
  value, and the certificate's status, bound and provenance under `certificate`: scoring it
  gives a gap of 0 (on the lossy set, where `value` is a policy's, the plan's gap is the value
  of adaptivity).

## A plan, and how to score it

A plan gives the robot's lattice point in each slot t = 0..T-1 (`positions`, the first the
start, consecutive ones one legal move apart) and the sensor it uploads from there, an index
into the instance's `sensors`, or `null` for none (`schedule`):

```json
{{"positions": [[0, 0], [1, 0], ...], "schedule": [null, 2, ...]}}
```

A submission adds the instance (`instance`, or `instance_sha256`), the `objective` and,
optionally, the `value` you claim. With voiopt installed (`pip install voiopt`):

```
voiopt bench score my-result.json                    # re-simulated, gaps to the certificate
voiopt bench score plan.json --instance NAME --objective OBJ   # a bare plan
voiopt bench score my-results/*.json --json          # or --csv: machine-readable
voiopt bench check my-result.json                    # the checker: exit status below
```

The gap to the bound is |bound - value| / |bound|; the gap to the best known value is the same
to `value`, negative when your plan is better than the best known one.

| exit status of `bench check` | meaning |
|---|---|
{codes}
"""
