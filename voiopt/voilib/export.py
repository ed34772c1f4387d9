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


def solution_name(name: str, objective: str) -> str:
    """The solution file of an instance and objective, under ``solutions/``."""
    return f"{name}__{objective}.json"


def solution(name: str, objective: str, sha256: str, cert: dict[str, Any]) -> dict[str, Any]:
    """A certificate's plan as a submission: ``voiopt bench score`` and ``bench check`` read it."""
    return {"instance": name, "instance_sha256": sha256, "objective": objective, "plan": cert["plan"],
            "value": cert["value"],
            "certificate": {"status": cert["status"], "bound": cert["bound"], "provenance": provenance(cert)}}


def readme(version: str, rows: list[dict[str, Any]]) -> str:
    """The README of an exported VoI-Lib: the table of certified values (``table_rows``), the
    files, and how to score a plan."""
    cols = ("name", "N", "T", "area", "rules", *OBJECTIVES)
    table = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    table += ["| " + " | ".join(str(r[c]) for c in cols) + " |" for r in rows]
    codes = "\n".join(f"| {k} | {v} |" for k, v in CHECK_CODES.items())
    return f"""# VoI-Lib {version}

Benchmark instances for planning a mobile robot's path and upload schedule that collects status
updates from sensors, maximising value of information (VoI) or minimising age of information
(AoI). Written by `voiopt bench export`; the model is voiopt's MODEL.md. Each certificate gives
the optimum of an objective (one number), or `[lower, upper]` where the optimum is still open.

## Certified values

{chr(10).join(table)}

`min-voi` and `mean-min-voi` are maximised; `max-aoi` and `mean-max-aoi` are minimised.

## Files

- `NAME.json`: an instance (MODEL.md section 1). Its identity is the sha256 of its canonical
  JSON: Python's `json.dumps(d, sort_keys=True, separators=(",", ":"))`.
- `certificates.json`: per instance its `sha256`, and per objective the certificate: `status`
  (`optimal`, or `bounded`: the optimum lies between `value` and `bound`), `value` (the
  simulated value of `plan`), `bound` (proven), `plan`, `method` and `bound_method`, each
  certifying method's own result in `checks`, and `provenance`: `proved_by` (method,
  voiopt version, UTC date; `null` where the date was not recorded), `found_by` and
  `confirmed_by` (the other methods that proved the same optimum independently).
- `solutions/NAME__OBJECTIVE.json`: the certificate's plan as a submission (below), with its
  value, and the certificate's status, bound and provenance under `certificate`: scoring it
  gives a gap of 0.

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
