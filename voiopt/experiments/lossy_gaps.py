"""Gap reports on lossy instances (MODEL.md section 11): every value says how it was computed
(exact, or Monte Carlo with its 95 % CI and scenario count) and every bound its kind.

The headline gap of a run is to the tightest *proven* bound of its instance over every method
and seed (exact, the optimal policy's value, or lossless: both proven; an exact bound is taken
over a lossless one of the same number). The tightest *statistical* bound (information
relaxation, a one-sided 95 % confidence limit, never called proven) gets a gap of its own,
in columns named statistical. A Monte Carlo value's gap is computed at its estimate, with the
range its CI ends imply; it is signed (an estimate may lie past a bound by chance, and its gap
is then below 0, not folded back to a positive number).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from voiopt import objectives
from voiopt.core.result import BoundKind, Evaluation, Result
from voiopt.errors import OptionError
from voiopt.objectives import TINY

# gaps.csv's columns on a report with some lossy instance (empty on a lossless instance's rows)
LOSSY_COLUMNS = ["evaluation", "samples", "value_ci_low", "value_ci_high", "bound_kind", "best_bound_kind",
                 "gap_ci_low", "gap_ci_high", "statistical_bound", "statistical_bound_kind", "statistical_gap",
                 "statistical_gap_ci_low", "statistical_gap_ci_high"]


def check_samples(samples: int | None, ir_samples: int | None) -> dict[str, int]:
    """--samples (a Monte Carlo value's scenarios, at least 2 for a CI) and --ir-samples (the
    information relaxation's: 0 for none, or at least 2), for the methods that take them; only
    those given, so that a sweep without them records the settings it always did."""
    given = {}
    for flag, key, value, zero in (("--samples", "samples", samples, False), ("--ir-samples", "ir_samples", ir_samples, True)):
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, int) or not (value >= 2 or (zero and value == 0)):
            raise OptionError(f"{flag}: must be an integer >= 2{' (or 0: none)' if zero else ''}, got {value!r}")
        given[key] = value
    return given


def proven(r: Result) -> bool:
    """Whether a result's bound is proven: every lossless result's is, a lossy one's by its kind."""
    return r.bound is not None and (r.bound_kind is None or r.bound_kind.proven)


def statistical(r: Result) -> bool:
    return r.bound is not None and r.bound_kind is not None and not r.bound_kind.proven


def tightest_proven(objective, group: Sequence[Result]) -> tuple[float | None, BoundKind | None]:
    """The tightest proven bound over the results of an instance, and its kind (None on a
    lossless instance); an exact bound wins a tie with a lossless one."""
    mine = [r for r in group if proven(r)]
    best = objectives.tightest(objective, (r.bound for r in mine))
    kinds = {r.bound_kind for r in mine if r.bound == best}
    if best is None or kinds == {None}:
        return best, None
    return best, BoundKind.EXACT if BoundKind.EXACT in kinds else BoundKind.LOSSLESS


def tightest_statistical(objective, group: Sequence[Result]) -> float | None:
    return objectives.tightest(objective, (r.bound for r in group if statistical(r)))


def signed_gap(objective, value: float | None, bound: float | None) -> float | None:
    """(bound - value) / |bound| when maximising, (value - bound) / |bound| when minimising:
    below 0 where a value lies past the bound (an estimate's noise, or a statistical bound's
    miss)."""
    if value is None or bound is None:
        return None
    return ((bound - value) if objectives.get(objective).maximise else (value - bound)) / max(abs(bound), TINY)


def gap_range(objective, ci: tuple[float, float] | None, bound: float | None) -> tuple[float | None, float | None]:
    """The smallest and largest gap of a value anywhere in its CI."""
    if ci is None or bound is None:
        return None, None
    ends = sorted(signed_gap(objective, v, bound) for v in ci)
    return ends[0], ends[1]


def lossy_fields(r: Result, group: Sequence[Result], objective) -> dict[str, Any]:
    """A row's lossy columns (every one empty for a lossless result or a run with no value),
    and its headline ``gap`` and ``best_bound`` (to the tightest proven bound)."""
    if r.evaluation is None:
        return dict.fromkeys(LOSSY_COLUMNS)
    best, kind = tightest_proven(objective, group)
    stat = tightest_statistical(objective, group)
    mc = r.evaluation == Evaluation.MONTE_CARLO
    # an exact value is never past a proven bound (Result.lossy checks it): the usual gap; an estimate's is signed
    gap = signed_gap(objective, r.value, best) if mc else objectives.gap(r.value, best)
    ci = r.value_ci if mc else None
    low, high = gap_range(objective, ci, best)
    s_low, s_high = gap_range(objective, ci, stat)
    return {
        "evaluation": r.evaluation, "samples": r.samples if mc else None,
        "value_ci_low": None if ci is None else ci[0], "value_ci_high": None if ci is None else ci[1],
        "bound_kind": r.bound_kind, "best_bound": best, "best_bound_kind": kind, "gap": gap,
        "gap_ci_low": low, "gap_ci_high": high, "statistical_bound": stat,
        "statistical_bound_kind": None if stat is None else BoundKind.INFORMATION_RELAXATION,
        "statistical_gap": signed_gap(objective, r.value, stat), "statistical_gap_ci_low": s_low,
        "statistical_gap_ci_high": s_high,
    }


def _value_text(row: dict[str, Any]) -> str:
    if row["value"] is None:
        return "-"
    if row["evaluation"] == Evaluation.MONTE_CARLO:
        half = (row["value_ci_high"] - row["value_ci_low"]) / 2
        return f"{row['value']:.6g} ± {half_width(half)} (monte-carlo, {row['samples']} scenarios)"
    return f"{row['value']:.6g} (exact)"


def half_width(h: float) -> str:
    """A CI's half-width as people read it: whole numbers from 1,000 on, else 3 significant figures."""
    return f"{h:,.0f}" if abs(h) >= 1000 else f"{h:.3g}"


def _gap_text(gap, low, high, kind, word: str) -> str:
    if gap is None:
        return "-"
    spread = "" if low is None else f" [{objectives.show_gap(low)}, {objectives.show_gap(high)}]"
    return f"{objectives.show_gap(gap)}{spread} ({word}, to {kind})"


LOSSY_TABLE = ("instance", "method", "seed", "status", "value", "its bound", "gap to the proven bound",
               "statistical gap")


def lossy_markdown(rows: Sequence[dict[str, Any]]) -> list[str]:
    """summary.md's section on the lossy instances' runs (nothing if there are none)."""
    mine = [r for r in rows if r.get("evaluation") is not None]
    if not mine:
        return []
    lines = [
        "", "## Lossy instances", "",
        "Each value is the expected objective, exact or a Monte Carlo estimate ± the half-width of its "
        "95 % CI. The gap columns of the table above are to the tightest proven bound (exact or "
        "lossless); a Monte Carlo value's gap is an estimate, with [the range its CI implies]. A gap to "
        "an information-relaxation bound is statistical (a one-sided 95 % confidence limit, never proven) "
        "and is never in the table above; where several methods give one, the least is taken, whose "
        "confidence is lower than each one's. A gap below 0 is an estimate or a statistical bound's miss.",
        "",
    ]
    lines += ["| " + " | ".join(LOSSY_TABLE) + " |", "|---|---|---:|---|---|---|---|---|"]
    for r in mine:
        own = "-" if r["bound"] is None else f"{r['bound']:.6g} ({r['bound_kind']})"
        headline = _gap_text(r["gap"], r["gap_ci_low"], r["gap_ci_high"], r["best_bound_kind"],
                             "estimate" if r["evaluation"] == Evaluation.MONTE_CARLO else "proven")
        stat = _gap_text(r["statistical_gap"], r["statistical_gap_ci_low"], r["statistical_gap_ci_high"],
                         r["statistical_bound_kind"], "statistical")
        seed = "-" if r.get("seed") is None else r["seed"]
        lines.append(f"| {r['instance']} | {r['method']} | {seed} | {r['status']} | {_value_text(r)} | {own} | "
                     f"{headline} | {stat} |")
    return lines
