"""VoI-Lib's certificates as a record: who proved each one (provenance), and when one may
replace another (``verdict``: never weaker, never in disagreement; docs/voilib.md)."""

from __future__ import annotations

import datetime
import hashlib
import json
from typing import Any

from voiopt.core.instance import Instance
from voiopt.core.result import OPTIMAL_RTOL, BoundKind, Evaluation
from voiopt.objectives import OBJECTIVES, gap


def instance_hash(inst: Instance) -> str:
    """sha256 of the instance's canonical JSON (sorted keys, no spaces): its identity."""
    text = json.dumps(inst.to_dict(), sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def same(a: float, b: float) -> bool:
    """Two proofs of an optimum agree: within the relative OPTIMAL_RTOL (certify's rule)."""
    return gap(a, b) <= OPTIMAL_RTOL


def provenance(cert: dict[str, Any]) -> dict[str, Any]:
    """Who proved a certificate: ``proved_by`` (the method that proved its bound, the voiopt
    version, the UTC date or None where it was not recorded), ``found_by`` (the method of its
    plan) and ``confirmed_by`` (the other certifying methods that proved the same optimum on
    their own). A certificate made before provenance was recorded gets it from its own
    fields (``bound_method``, ``method``, ``voiopt_version``, ``checks``), with the date None."""
    if isinstance(cert.get("provenance"), dict):
        return cert["provenance"]
    return make_provenance(cert, date=None)


def make_provenance(cert: dict[str, Any], date: str | None) -> dict[str, Any]:
    """The provenance of a certificate from its fields, proved on ``date`` (ISO, UTC, or None)."""
    prover = cert.get("bound_method")
    confirmed = []
    if cert.get("status") == "optimal":
        confirmed = sorted(m for m, c in (cert.get("checks") or {}).items()
                           if m != prover and c.get("status") == "optimal" and c.get("value") is not None
                           and same(c["value"], cert["value"]))
    return {"proved_by": {"method": prover, "voiopt_version": cert.get("voiopt_version"), "date": date},
            "found_by": cert.get("method"), "confirmed_by": confirmed}


def today() -> str:
    """The UTC date a certificate is made, ISO 8601."""
    return datetime.datetime.now(datetime.timezone.utc).date().isoformat()


def interval(objective: str, cert: dict[str, Any]) -> tuple[float, float]:
    """Where a certificate puts the optimum: [value, bound] in increasing order; a side without
    a proven bound is open (infinite)."""
    value, bound = cert["value"], cert.get("bound")
    if bound is None:
        bound = float("inf") if OBJECTIVES[objective] == "max" else float("-inf")
    return min(value, bound), max(value, bound)


def verdict(objective: str, old: dict[str, Any], new: dict[str, Any]) -> str | None:
    """Why ``new`` may not replace ``old`` ("disagrees ...", "is weaker ..."), or None if it may:
    their intervals must meet (to the optimality tolerance), a proven optimum stays proven, and
    an open interval does not widen."""
    why = lossy_verdict(old, new)
    if why is not None:
        return why
    (lo_old, hi_old), (lo_new, hi_new) = interval(objective, old), interval(objective, new)
    slack = OPTIMAL_RTOL * max(abs(lo_old), abs(hi_old), abs(lo_new), abs(hi_new), 1e-300)
    if lo_new > hi_old + slack or lo_old > hi_new + slack:
        return (f"disagrees: it puts the optimum in [{lo_new!r}, {hi_new!r}], the shipped certificate in "
                f"[{lo_old!r}, {hi_old!r}]")
    if old["status"] == "optimal" and new["status"] != "optimal":
        return f"is weaker: {new['status']} [{lo_new!r}, {hi_new!r}] would replace the proven optimum {old['value']!r}"
    if old["status"] == "optimal" and new["status"] == "optimal" and not same(old["value"], new["value"]):
        return f"disagrees: it proves {new['value']!r}, the shipped certificate {old['value']!r}"
    g_old, g_new = gap(old["value"], old.get("bound")), gap(new["value"], new.get("bound"))
    if old["status"] != "optimal" and new["status"] != "optimal" and g_old is not None \
            and (g_new is None or g_new > g_old):
        return f"is weaker: its gap {g_new!r} is wider than the shipped {g_old!r}"
    return None


def lossy_verdict(old: dict[str, Any], new: dict[str, Any]) -> str | None:
    """The labels of lossy certificates (MODEL.md section 11), checked before the intervals: a
    certificate's ``bound`` is proven (a statistical one is never), ``optimal`` needs an exact
    value and an exact bound, and an exact label is never replaced by a statistical one."""
    kind, evaluation = new.get("bound_kind"), new.get("evaluation")
    if old.get("bound_kind") is not None and (kind is None or evaluation is None):
        return "has no bound_kind or evaluation: a certificate of a lossy instance says what its numbers are"
    if kind is not None and kind not in BoundKind.__members__.values():
        return f"has bound_kind {kind!r}, none of {', '.join(k.value for k in BoundKind)}"
    if kind is not None and not BoundKind(kind).proven:
        return f"is weaker: its bound is {kind}, statistical, where a certificate's bound is proven"
    if new.get("status") == "optimal" and kind is not None and (kind != BoundKind.EXACT or evaluation != Evaluation.EXACT):
        return f"claims optimal with a {evaluation} value and a {kind} bound: optimal needs both exact"
    if old.get("evaluation") == Evaluation.EXACT and evaluation == Evaluation.MONTE_CARLO:
        return "is weaker: a monte-carlo value would replace an exact one"
    if old.get("bound_kind") == BoundKind.EXACT and kind != BoundKind.EXACT:
        return f"is weaker: a {kind} bound would replace an exact one"
    return None
