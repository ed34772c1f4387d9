"""Shared fixtures: tiny random instances for cross-checks against the oracles in tests/oracles/."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))  # make tests/oracles importable

import voiopt  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def tiny_instances(count: int = 30, seed: int = 12345) -> list[voiopt.Instance]:
    """A varied set of tiny networks: normal, low-VoI (rho small, long horizon), low power."""
    out = []
    kinds = [
        dict(rho=(0.0, 1.0), power_w=1.0),
        dict(rho=(0.05, 0.3), power_w=1.0, initial_aoi=(3, 8)),  # min-VoI optimum far below 1 bit/s
        dict(rho=(0.3, 0.9), power_w=0.01),  # distance matters
        dict(rho=(0.3, 0.9), power_w=0.001),
    ]
    for k in range(count):
        kind = kinds[k % len(kinds)]
        n = 1 + k % 3
        horizon = 3 + k % 4
        size = 2.0 if k % 2 else 3.0
        out.append(
            voiopt.generate(n, horizon, width=size, height=2.0, seed=seed + k, name=f"tiny-{k:02d}", **kind)
        )
    return out


@pytest.fixture(scope="session")
def case_study():
    return voiopt.load(ROOT / "instances" / "case-study.json")
