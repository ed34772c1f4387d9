"""The four objectives of MODEL.md section 5: the only place their properties are defined.

Every objective maximises or minimises an aggregate over slots t = 1..T of a per-slot extreme
over sensors. Solvers work with a sensor's *worth*: its VoI V_i(t) for the VoI objectives and
minus its age, -A_i(t), for the AoI objectives, so that every objective is a maximisation of
the minimum worth (per slot and summed, or over all slots).
"""

from __future__ import annotations

import numpy as np

from voiopt.errors import OptionError
from voiopt.runtime.status import Word

TINY = 1e-300  # the denominator floor of a relative gap


class Worth(Word):
    """What a sensor is worth to an objective: its VoI, or minus its age. It equals its word
    ("voi", "aoi"), as results and files write it."""

    VOI = "voi"  # worth = V_i(t)
    AOI = "aoi"  # worth = -A_i(t)


class Objective(str):
    """One of the four objectives of MODEL.md section 5, resolved from its name once at the API
    edge (``get``) and passed as it is from there on. It is its name, so it keys ``metrics``,
    prints and reads in JSON as the name, and it carries what solvers ask of it: ``sense``,
    ``worth``, ``per_slot`` and ``maximise``. Two objectives of one name are the same object."""

    sense: str  # "max" or "min"
    worth: Worth
    per_slot: bool  # the mean over slots of a per-slot extreme (else the extreme over all slots)

    def __new__(cls, name: str, sense: str, worth: Worth, per_slot: bool) -> Objective:
        self = super().__new__(cls, name)
        object.__setattr__(self, "sense", sense)
        object.__setattr__(self, "worth", Worth(worth))
        object.__setattr__(self, "per_slot", per_slot)
        return self

    def __setattr__(self, name: str, value) -> None:
        raise AttributeError(f"an Objective is frozen: cannot set {name!r}")

    def __reduce__(self):  # a pool worker gets the same objective back, by its name
        return get, (str(self),)

    @property
    def name(self) -> str:
        return str(self)

    @property
    def maximise(self) -> bool:
        return self.sense == "max"

    @property
    def voi(self) -> bool:
        """Worth is VoI (else minus the age)."""
        return self.worth is Worth.VOI

    def better(self, a: float, b: float) -> bool:
        """Is value a strictly better than value b?"""
        return a > b if self.maximise else a < b

    def best(self, values):
        """The best of some values (None if there are none)."""
        return _extreme(values, largest=self.maximise)

    def tightest(self, bounds):
        """The tightest of some proven bounds (None if there are none)."""
        return _extreme(bounds, largest=not self.maximise)


_ALL = (
    Objective("min-voi", "max", Worth.VOI, per_slot=False),  # the paper's max-min formulation
    Objective("mean-min-voi", "max", Worth.VOI, per_slot=True),  # the paper's figures and reward
    Objective("max-aoi", "min", Worth.AOI, per_slot=False),
    Objective("mean-max-aoi", "min", Worth.AOI, per_slot=True),  # the paper's "AoI-optimal" baseline
)
BY_NAME: dict[str, Objective] = {str(o): o for o in _ALL}
OBJECTIVES: dict[str, str] = {str(o): o.sense for o in _ALL}  # name -> sense
DEFAULT = BY_NAME["mean-min-voi"]  # the paper's figures
AOI_DEFAULT = BY_NAME["mean-max-aoi"]  # the paper's "AoI-optimal" scheme
MIN_VOI, MEAN_MIN_VOI, MAX_AOI, MEAN_MAX_AOI = _ALL


def get(name: str | Objective) -> Objective:
    """The objective called ``name`` (an Objective is its own); an OptionError naming the
    choices otherwise. This is the edge where a name becomes an Objective."""
    try:
        return BY_NAME[name]
    except (KeyError, TypeError):
        raise OptionError(f"objective: unknown objective {name!r} (choose from {', '.join(BY_NAME)})") from None


def sense(name: str | Objective) -> str:
    return get(name).sense


def better(objective: str | Objective, a: float, b: float) -> bool:
    """Is value a strictly better than value b for this objective?"""
    return get(objective).better(a, b)


def _extreme(values, largest: bool):
    values = [v for v in values if v is not None]
    return (max(values) if largest else min(values)) if values else None


def best(objective: str | Objective, values):
    """The best of some values (None if there are none)."""
    return get(objective).best(values)


def tightest(objective: str | Objective, bounds):
    """The tightest of some proven bounds (None if there are none)."""
    return get(objective).tightest(bounds)


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
