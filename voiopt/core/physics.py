"""Units, SNR and the value of information of MODEL.md section 4, vectorised and careful.

    V = -B log2(1 - x),   x = rho^A * P g0 / (B N0 q^2 + P g0)

For x <= 1/2 we use log1p(-x); for x close to 1 we use the exact complement
1 - x = (B N0 q^2 + P g0 (1 - rho^A)) / (B N0 q^2 + P g0) with 1 - rho^A = -expm1(A ln rho),
so neither tiny VoI (huge ages, tiny rho) nor huge VoI (q = 0, rho near 1) loses precision.

The logarithms and exponentials are libm's (Python's ``math``, or for large arrays the same
libm functions called from a compiled loop, voiopt.runtime.libm), element by element, each
argument at its own shape before it broadcasts, not numpy's: numpy has its own SIMD versions
on CPUs with AVX-512, whose last bit differs from libm's, so the same plan simulated to
different values on two machines (VoI-Lib's certificates record values exactly; 4 of its 60
mean values moved by one ulp).
"""

from __future__ import annotations

import math
import sys

import numpy as np

from voiopt.core.instance import Channel
from voiopt.runtime.stop import halt_if_asked

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
    a_log_rho = aoi * _through_libm(_log, rho)  # the arguments are kept at their own shapes until they broadcast
    log_pg_bn = _through_libm(_log, bn + pg)
    log_x = a_log_rho + _through_libm(_log, pg) - log_pg_bn
    # Ages >= 1 give a_log_rho <= 0, so exp and expm1 cannot overflow; callers that tabulate
    # ages <= 0 as well (and mask them, as models/uploads.py does) get +inf there.
    x = _through_libm(_exp, log_x)
    with np.errstate(invalid="ignore", over="ignore"):
        one_minus_rho_a = -_through_libm(_expm1, a_log_rho)
        nats = np.empty(x.shape)
        small = x <= 0.5  # each element takes one of the two forms (nan: the second, as before)
        nats[small] = -_through_libm(_log1p, -x[small])
        large = ~small
        nats[large] = (np.broadcast_to(log_pg_bn, x.shape)[large]
                       - _through_libm(_log, np.broadcast_to(bn + pg * one_minus_rho_a, x.shape)[large]))
    out = channel.bandwidth_hz * nats / LN2
    return out if out.ndim else float(out)


def voi_blocks(aoi, distance, rho, power_w, channel: Channel, *, axis: int, block: int, stop=None) -> np.ndarray:
    """``voi`` of arguments that broadcast to one shape, computed a few slices along ``axis`` at
    a time (about ``block`` entries each), ``stop`` (voiopt.runtime.stop.Stop) checked between blocks:
    voiopt.runtime.stop.Stopped. An entry depends on its own arguments alone, so the blocks change no
    bit; only the arguments that vary along ``axis`` are sliced, the others are passed whole
    (each is then taken through libm once, not once per entry). Every argument has the result's
    number of axes, or none. For the tables that grow as T^2 (MDP, MILP)."""
    args = [np.asarray(a, dtype=float) for a in (aoi, distance, rho, power_w)]
    shape = np.broadcast_shapes(*(a.shape for a in args))
    out = np.empty(shape)
    step = max(1, block // max(1, out.size // max(1, shape[axis])))
    for lo in range(0, shape[axis], step):
        if lo:
            halt_if_asked(stop)
        cut = (slice(None),) * axis + (slice(lo, lo + step),)
        part = [a[cut] if a.ndim and a.shape[axis] > 1 else a for a in args]
        out[cut] = voi(*part, channel)
    return out


def voi_of_x(x, bandwidth_hz: float):
    """g(x) = -B log2(1 - x), for x = rho^t * score (MODEL.md section 4)."""
    out = -bandwidth_hz * _through_libm(_log1p, -np.asarray(x, float)) / LN2
    return out if out.ndim else float(out)


def _through_libm(f, x) -> np.ndarray:
    """f (a scalar function of floats) of every element of x: a few hundred nanoseconds each
    through Python's math, about 20 ns for a large array, with the same bits (voiopt.runtime.libm)."""
    a = np.asarray(x, dtype=float)
    if compiled(a.size):
        from voiopt.runtime import libm

        out = libm.apply(_CODES[f], a)
        if out is not None:
            return out
    return np.fromiter(map(f, a.ravel().tolist()), float, a.size).reshape(a.shape)


def _log(v: float) -> float:
    return math.log(v) if v > 0 else -math.inf if v == 0 else math.nan


def _log1p(v: float) -> float:
    return math.log1p(v) if v > -1 else -math.inf if v == -1 else math.nan


def _exp(v: float) -> float:
    try:
        return math.exp(v)
    except OverflowError:
        return math.inf


def _expm1(v: float) -> float:
    try:
        return math.expm1(v)
    except OverflowError:
        return math.inf


_CODES = {_log: 0, _log1p: 1, _exp: 2, _expm1: 3}  # voiopt.runtime.libm's LOG, LOG1P, EXP, EXPM1
COMPILED_FROM = 1 << 18  # elements from which the compiled loop is loaded (numba's start: 0.3 to 0.7 s)
COMPILED_FROM_LOADED = 1 << 10  # elements from which it is used once loaded


def compiled(size: int) -> bool:
    """Whether libm's functions of an array of ``size`` elements are called from a compiled
    loop (voiopt.runtime.libm) rather than through Python's math, one element at a time. Smaller
    arrays, such as greedy's blocks of 2^16 pairs, use it only once it is loaded, so that a
    time-limited solve does not pay numba's start for them."""
    if size >= COMPILED_FROM:
        from voiopt.runtime import libm

        return not libm.USING_SVML
    loaded = sys.modules.get("voiopt.runtime.libm")
    return size >= COMPILED_FROM_LOADED and loaded is not None and loaded.ready
