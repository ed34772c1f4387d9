"""The four objectives of MODEL.md section 5: the only place their properties are defined.

Every objective maximises or minimises an aggregate over slots t = 1..T of a per-slot extreme
over sensors. Solvers work with a sensor's *worth*: its VoI V_i(t) for the VoI objectives and
minus its age, -A_i(t), for the AoI objectives, so that every objective is a maximisation of
the minimum worth (per slot and summed, or over all slots).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from voiopt.errors import OptionError

TINY = 1e-300  # the denominator floor of a relative gap


@dataclass(frozen=True)
class Objective:
    name: str
    sense: str  # "max" or "min"
    worth: str  # "voi" (worth = V) or "aoi" (worth = -A)
    per_slot: bool  # the mean over slots of a per-slot extreme (else the extreme over all slots)

    @property
    def maximise(self) -> bool:
        return self.sense == "max"


_ALL = (
    Objective("min-voi", "max", "voi", per_slot=False),  # the paper's max-min formulation
    Objective("mean-min-voi", "max", "voi", per_slot=True),  # the paper's figures and reward
    Objective("max-aoi", "min", "aoi", per_slot=False),
    Objective("mean-max-aoi", "min", "aoi", per_slot=True),  # the paper's "AoI-optimal" baseline
)
BY_NAME: dict[str, Objective] = {o.name: o for o in _ALL}
OBJECTIVES: dict[str, str] = {o.name: o.sense for o in _ALL}  # name -> sense
DEFAULT = "mean-min-voi"  # the paper's figures
AOI_DEFAULT = "mean-max-aoi"  # the paper's "AoI-optimal" scheme


def get(name: str) -> Objective:
    """The objective called ``name``; an OptionError naming the choices otherwise."""
    try:
        return BY_NAME[name]
    except (KeyError, TypeError):
        raise OptionError(f"objective: unknown objective {name!r} (choose from {', '.join(BY_NAME)})") from None


def check_objective(name: str) -> str:
    return get(name).name


def sense(name: str) -> str:
    return get(name).sense


def better(objective: str, a: float, b: float) -> bool:
    """Is value a strictly better than value b for this objective?"""
    return a > b if get(objective).maximise else a < b


def _extreme(values, largest: bool):
    values = [v for v in values if v is not None]
    return (max(values) if largest else min(values)) if values else None


def best(objective: str, values):
    """The best of some values (None if there are none)."""
    return _extreme(values, largest=get(objective).maximise)


def tightest(objective: str, bounds):
    """The tightest of some proven bounds (None if there are none)."""
    return _extreme(bounds, largest=not get(objective).maximise)


def gap(value: float | None, bound: float | None) -> float | None:
    """The relative gap |bound - value| / max(|bound|, tiny) of MODEL.md section 6: the one
    gap formula of voiopt (results, reports, the demo, figures)."""
    if value is None or bound is None:
        return None
    return abs(bound - value) / max(abs(bound), TINY)


GAP_NOISE = 1e-12  # relative gaps below this are rounding between a bound and a simulated value


def show_gap(g: float | None, digits: int = 3) -> str:
    """A gap as people read it: a percentage to ``digits`` significant figures, "-" if there is
    none, and "0 %" below GAP_NOISE (a proven optimum whose bound and simulated value differ
    in the last bits). Results keep the exact gap."""
    if g is None:
        return "-"
    return "0 %" if abs(g) < GAP_NOISE else f"{100 * g:.{digits}g} %"


def metrics_of(aoi: np.ndarray, voi: np.ndarray) -> dict[str, float]:
    """The four objectives of per-slot ages and VoIs (rows t = 0..T; row 0 is not scored)."""
    a, v = aoi[1:], voi[1:]
    return {
        "min-voi": float(v.min()),
        "mean-min-voi": float(v.min(axis=1).mean()),
        "max-aoi": int(a.max()),
        "mean-max-aoi": float(a.max(axis=1).mean()),
    }
