"""Success probabilities of uploads over lossy links (MODEL.md section 11).

- no ``links``: every upload succeeds, p = 1;
- ``bernoulli``: p_i = ``sensors[i].success`` if given, else ``links.success``;
- ``rayleigh``: p_i(d) = exp(-gamma B N0 d^2 / (P_i g0)), gamma = 10^(snr_threshold_db / 10),
  unless ``sensors[i].success`` is given.

``links`` changes whether an upload in range succeeds, never which sensors are in range. The
Rayleigh exponent is computed as written, and through its logarithm where that overflows,
so that no finite threshold gives a NaN (p = 1 at d = 0, p = 0 where the exponent overflows).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from voiopt.core import physics
from voiopt.core.instance import Instance
from voiopt.grid import lattice as lattice_mod

LN10_OVER_10 = math.log(10.0) / 10.0


def success_probability(instance: Instance, sensor: int, distance):
    """p_i(d) of sensor ``sensor`` uploading from ``distance`` (a float or an array of them):
    a float for a scalar distance, else an array of the distance's shape."""
    d = np.asarray(distance, dtype=float)
    fixed = _fixed(instance, sensor)
    if fixed is not None:
        out = np.full(d.shape, fixed)
    else:
        exponent = _rayleigh_exponent(instance, sensor, d)
        out = np.exp(-exponent)
    return float(out) if out.ndim == 0 else out


def _rayleigh_exponent(instance: Instance, sensor: int, d: np.ndarray) -> np.ndarray:
    """gamma B N0 d^2 / (P_i g0), as written; where that overflows (a threshold of thousands of
    dB), through its logarithm, which is finite for d > 0 (0 at d = 0, inf past the floats)."""
    s, ch = instance.sensors[sensor], instance.channel
    bn0, pg = ch.bandwidth_hz * physics.noise_w_per_hz(ch), s.power_w * physics.g0_linear(ch)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        gamma = np.power(10.0, instance.links.snr_threshold_db / 10.0)
        exponent = gamma * bn0 * d * d / pg
        bad = ~np.isfinite(exponent)
        if bad.any():
            log_c = instance.links.snr_threshold_db * LN10_OVER_10 + math.log(bn0) - math.log(pg)
            exponent = np.where(bad, np.exp(log_c + 2.0 * np.log(d)), exponent)
    return exponent


def _fixed(instance: Instance, sensor: int) -> float | None:
    """The sensor's probability where it does not depend on the distance, else None."""
    links = instance.links
    if links is None:
        return 1.0
    own = instance.sensors[sensor].success
    if own is not None:
        return own
    return links.success if links.model == "bernoulli" else None


def success_table(instance: Instance, lat=None) -> np.ndarray:
    """(lattice points, N) float64: p_i at each lattice point for each sensor in range there,
    0.0 where the sensor is out of range (``lat`` is ``voiopt.grid.lattice.build(instance)``)."""
    lat = lattice_mod.build(instance) if lat is None else lat
    out = np.zeros((lat.n_points, instance.n_sensors))
    for i in range(instance.n_sensors):
        near = lat.in_range[i]
        out[near, i] = success_probability(instance, i, lat.distance[i, near])
    return out


def is_lossy(instance: Instance) -> bool:
    """Whether some upload a robot can make may fail: some success probability < 1 at an open
    lattice point in range. An instance with ``links`` whose every probability is 1 is not
    lossy, and behaves bit for bit as without them."""
    return instance.links is not None and _lossy(instance)


@functools.lru_cache(maxsize=64)
def _lossy(instance: Instance) -> bool:
    lat = lattice_mod.build(instance)
    table = success_table(instance, lat)
    usable = lat.in_range.T & ~lat.blocked[:, None]
    return bool((table[usable] < 1.0).any())


def without_links(instance: Instance) -> Instance:
    """The lossless instance of the same network: no ``links``, no per-sensor ``success``.
    Every realised run of every policy is one of its plans (MODEL.md section 11)."""
    if instance.links is None:
        return instance
    sensors = tuple(dataclasses.replace(s, success=None) for s in instance.sensors)
    return dataclasses.replace(instance, links=None, sensors=sensors)
