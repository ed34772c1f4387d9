"""Units, SNR and the value of information of MODEL.md section 4, vectorised and careful.

    V = -B log2(1 - x),   x = rho^A * P g0 / (B N0 q^2 + P g0)

For x <= 1/2 we use log1p(-x); for x close to 1 we use the exact complement
1 - x = (B N0 q^2 + P g0 (1 - rho^A)) / (B N0 q^2 + P g0) with 1 - rho^A = -expm1(A ln rho),
so neither tiny VoI (huge ages, tiny rho) nor huge VoI (q = 0, rho near 1) loses precision.
"""

from __future__ import annotations

import math

import numpy as np

from voiopt.instance import Channel

LN2 = math.log(2.0)


def g0_linear(channel: Channel) -> float:
    """Channel power gain at 1 m, linear."""
    return 10.0 ** (channel.g0_db / 10.0)


def noise_w_per_hz(channel: Channel) -> float:
    """N0 in W/Hz from dBm/Hz."""
    return 10.0 ** (channel.noise_dbm_per_hz / 10.0) / 1000.0


def snr(power_w, distance, channel: Channel):
    """eta = P g0 d^-2 / (B N0), as in the paper (infinite at d = 0)."""
    d2 = np.asarray(distance, dtype=float) ** 2
    with np.errstate(divide="ignore"):
        return np.asarray(power_w, float) * g0_linear(channel) / (d2 * channel.bandwidth_hz * noise_w_per_hz(channel))


def distance_factor(power_w, distance, channel: Channel):
    """c = P g0 / (B N0 d^2 + P g0) in (0, 1]: the quality of an upload made at distance d."""
    pg = np.asarray(power_w, float) * g0_linear(channel)
    bn = channel.bandwidth_hz * noise_w_per_hz(channel)
    return pg / (bn * np.asarray(distance, float) ** 2 + pg)


def voi(aoi, distance, rho, power_w, channel: Channel):
    """V_i(t) in bit/s for age ``aoi`` and effective distance ``distance`` (arrays broadcast)."""
    aoi = np.asarray(aoi, dtype=float)
    rho = np.asarray(rho, dtype=float)
    pg = np.asarray(power_w, float) * g0_linear(channel)
    bn = channel.bandwidth_hz * noise_w_per_hz(channel) * np.asarray(distance, float) ** 2
    a_log_rho = aoi * np.log(rho)
    log_x = a_log_rho + np.log(pg) - np.log(bn + pg)
    # Ages >= 1 give a_log_rho <= 0, so exp and expm1 cannot overflow; callers that tabulate
    # ages <= 0 as well (and mask them, as models/uploads.py does) would otherwise print
    # overflow warnings for a tiny rho.
    with np.errstate(over="ignore"):
        x = np.exp(log_x)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        small = -np.log1p(-np.minimum(x, 0.5))
        one_minus_rho_a = -np.expm1(a_log_rho)
        large = np.log(bn + pg) - np.log(bn + pg * one_minus_rho_a)
    nats = np.where(x <= 0.5, small, large)
    out = channel.bandwidth_hz * nats / LN2
    return out if out.ndim else float(out)


def voi_of_x(x, bandwidth_hz: float):
    """g(x) = -B log2(1 - x), for x = rho^t * score (MODEL.md section 4)."""
    return -bandwidth_hz * np.log1p(-np.asarray(x, float)) / LN2
