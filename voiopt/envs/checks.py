"""What both environments check: actions, reset()'s options, sampled networks' arguments, and
whether an instance's reward can be normalised by a proven optimum."""

from __future__ import annotations

import inspect
from typing import Any

import numpy as np

from voiopt.core.instance import Instance
from voiopt.core.links import without_links
from voiopt.errors import OptionError
from voiopt.networks.generate import generate as generate_network
from voiopt.objectives import MEAN_MIN_VOI

SAMPLE = dict(n_sensors=4, horizon=30, width=5.0, height=5.0)  # the paper's setting, for sampled networks


def check_normalisable(instance: Instance) -> None:
    """The normalised reward divides by a proven optimum: an instance whose VoI-Lib certificate
    is still open has none (dp would search for it without end), so it is refused up front."""
    from voiopt.voilib import library as voilib

    interval = voilib.open_certificate(without_links(instance), MEAN_MIN_VOI)  # lossy: the optimum without links
    if interval is not None:
        raise OptionError(f"reward_mode: 'normalised' needs a proven optimum, and VoI-Lib's mean-min-voi certificate "
                          f"of {instance.name} is open ({interval}); use 'paper'")


def as_integer(action: Any, must: str = "an integer", what: str = "action") -> int:
    """An action as an int: a Python or numpy integer, or a one-element integer array (what
    agents pass). Anything else (0.7, "3", True) is refused, not truncated to an action."""
    whole = action.item() if isinstance(action, np.ndarray) and action.size == 1 else action
    if isinstance(whole, bool) or not isinstance(whole, (int, np.integer)):
        raise OptionError(f"{what}: must be {must}, got {action!r}")
    return int(whole)


def action_in(action: Any, n: int, what: str = "action") -> int:
    """An action of a space of ``n`` as an int: an integer (``as_integer``) in 0..n-1, else one
    line naming ``what``. The Gymnasium env's check and the PettingZoo env's, one helper."""
    a = as_integer(action, f"an integer in 0..{n - 1}", what)
    if not 0 <= a < n:
        raise OptionError(f"{what}: must be in 0..{n - 1}, got {a}")
    return a


def _dict(value: Any, field: str, must: str) -> dict:
    """A dict ({} for None); anything else is refused in one line naming ``field``."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise OptionError(f"{field}: must be {must}, got {value!r}")
    return value


def reset_options(options: Any) -> dict:
    """reset()'s options as a dict ({} for None); anything else is refused in one line."""
    return _dict(options, "options", "a dict such as {'instance': path}")


def check_sample(sample: Any) -> dict:
    """The keyword arguments of voiopt.networks.generate for sampled networks (without ``seed``)."""
    sample = _dict(sample, "sample", "a dict of voiopt.networks.generate's arguments")
    allowed = [k for k in inspect.signature(generate_network).parameters if k != "seed"]
    unknown = [k for k in sample if k not in allowed]
    if unknown:
        raise OptionError(f"sample: unknown key {unknown[0]!r} (allowed: {', '.join(allowed)})")
    if sample.get("robots", 1) != 1:  # a FleetVoIEnv is made from a fleet instance, not sampled
        raise OptionError(f"sample: robots: the env samples one-robot networks, got {sample['robots']!r} "
                          "(pass instance= a fleet's instance for several robots)")
    return sample
