"""The command line's lossy links (MODEL.md section 11): ``generate --links`` and how
``evaluate`` labels a plan's exact expected objectives."""

from __future__ import annotations

import argparse
import dataclasses
import math
from typing import Any

from voiopt.core.expectation import expected_metrics
from voiopt.core.instance import Instance, show
from voiopt.core.links import is_lossy
from voiopt.core.result import Evaluation
from voiopt.errors import OptionError

LINKS_HELP = ("lossy links (MODEL.md section 11): bernoulli:P, every upload succeeds with probability P in (0, 1]; "
              "or rayleigh:SNR_DB, Rayleigh fading with an SNR threshold of SNR_DB dB (default: none, every upload "
              "succeeds)")


def add_links_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--links", type=_links_argument, default=None, metavar="bernoulli:P|rayleigh:SNR_DB",
                        help=LINKS_HELP)


def _links_argument(text: str) -> dict[str, Any]:
    try:
        return parse_links(text)
    except OptionError as e:  # argparse names the option itself
        raise argparse.ArgumentTypeError(str(e).removeprefix("--links: ")) from None


def parse_links(text: str) -> dict[str, Any]:
    """``bernoulli:P`` or ``rayleigh:SNR_DB`` as an instance's ``links`` object; OptionError otherwise."""
    model, _, number = str(text).partition(":")
    try:
        value = float(number)
    except ValueError:
        value = math.nan
    if model == "bernoulli" and 0 < value <= 1:
        return {"model": "bernoulli", "success": value}
    if model == "rayleigh" and math.isfinite(value):
        return {"model": "rayleigh", "snr_threshold_db": value}
    raise OptionError(f"--links: must be bernoulli:P with 0 < P <= 1, or rayleigh:SNR_DB with a finite SNR_DB, "
                      f"got {show(text)}")


def metrics(instance: Instance, plan) -> dict[str, float]:
    """A plan's four objectives: the simulator's, or their exact expectations on a lossy instance."""
    return expected_metrics(instance, plan)


def title(instance: Instance) -> str:
    if not is_lossy(instance):
        return instance.name
    return f"{instance.name}: expected objectives over the upload outcomes (exact, lossy links)"


def solve_title(instance: Instance, result) -> str:
    """``solve``'s metrics table is untitled, but on a lossy instance it says what its numbers
    are: exact expectations, or Monte Carlo estimates (whose CI and count the summary gives)."""
    if not is_lossy(instance):
        return ""
    if result.evaluation == Evaluation.MONTE_CARLO:
        return (f"{instance.name}: expected objectives over the upload outcomes (Monte Carlo estimates over "
                f"{result.samples} scenarios, lossy links; the value's 95 % CI is above)")
    return title(instance)


def evaluation_json(instance: Instance, values: dict[str, float]) -> dict[str, Any]:
    """``evaluate --json``'s object: on a lossy instance it says that the metrics are exact expectations."""
    out: dict[str, Any] = {"instance": instance.name, "metrics": values}
    if is_lossy(instance):
        links = {k: v for k, v in dataclasses.asdict(instance.links).items() if v is not None}
        out.update(expected=True, evaluation="exact", links=links)
    return out
