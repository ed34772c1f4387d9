"""VoI against a 400-digit Decimal reference, including the edge cases of the issue."""

from __future__ import annotations

import math
import warnings
from decimal import Decimal, getcontext

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from voiopt.core import physics
from voiopt.core.instance import Channel

CH = Channel()


def reference_voi(aoi: int, q: float, rho: float, power: float, ch: Channel = CH) -> float:
    """-B log2(1 - P g0 rho^A / (B N0 q^2 + P g0)) in 400-digit decimal arithmetic."""
    getcontext().prec = 400  # x can be ~1e-300; 1 - x must keep its digits
    g0 = Decimal(10) ** (Decimal(repr(ch.g0_db)) / 10)
    n0 = Decimal(10) ** (Decimal(repr(ch.noise_dbm_per_hz)) / 10) / 1000
    b, p, r, d = Decimal(ch.bandwidth_hz), Decimal(power), Decimal(rho), Decimal(q)  # exact binary values
    x = p * g0 * r**aoi / (b * n0 * d * d + p * g0)
    if x == 0:
        return 0.0
    return float(-b * (1 - x).ln() / Decimal(2).ln())


def close(a: float, b: float, rtol: float = 1e-12) -> bool:
    return abs(a - b) <= rtol * abs(b) or (b == 0 and a == 0) or abs(a - b) < 1e-300


CASES = [
    (1, 0.0, 0.7, 1.0),  # q = 0: upload at the sensor's own position
    (1, 0.0, 1 - 1e-9, 1.0),  # x within 1e-9 of 1
    (1, 0.3, 1 - 1e-9, 100.0),
    (1, 1.0, 1e-6, 1.0),  # tiny rho
    (3, 1.0, 1e-6, 1.0),  # tiny rho, x = 1e-18
    (10_000, 1.0, 0.999, 1.0),  # huge age, still representable
    (10_000, 1.0, 0.5, 1.0),  # huge age, underflows to 0
    (10_000, 1.0, 1 - 1e-9, 1e-4),
    (5, 1.0, 0.6, 1e-6),  # very small power: distance dominates
    (5, 1.0, 0.6, 1e6),  # very large power
    (2, 0.7, 0.7, 0.01),
]


@pytest.mark.parametrize("aoi,q,rho,power", CASES)
def test_edge_cases_match_high_precision(aoi, q, rho, power):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        v = physics.voi(aoi, q, rho, power, CH)
    ref = reference_voi(aoi, q, rho, power)
    assert math.isfinite(v) and v >= 0
    if ref < 1e-300:
        assert v < 1e-290
    else:
        assert close(v, ref, 1e-11), (v, ref)


@settings(max_examples=200, deadline=None)
@given(
    st.integers(1, 10_000),
    st.floats(0, 5),
    st.floats(1e-6, 1 - 1e-9),
    st.floats(1e-4, 1e3),
)
def test_random_points_match_high_precision(aoi, q, rho, power):
    v = physics.voi(aoi, q, rho, power, CH)
    ref = reference_voi(aoi, q, rho, power)
    if ref < 1e-290:
        assert 0 <= v < 1e-280
    else:
        assert close(v, ref, 1e-10), (v, ref)


def test_vectorised_matches_scalar_and_is_monotone():
    aoi = np.arange(1, 60)[:, None]
    q = np.array([0.0, 0.5, 1.0])[None, :]
    v = physics.voi(aoi, q, 0.8, 0.01, CH)
    assert v.shape == (59, 3)
    assert v[7, 1] == physics.voi(8, 0.5, 0.8, 0.01, CH)
    assert np.all(np.diff(v, axis=0) < 0), "VoI falls with age"
    assert np.all(np.diff(v, axis=1) < 0), "VoI falls with distance"


def test_units_and_snr():
    assert physics.g0_linear(CH) == pytest.approx(1e-5)
    assert physics.noise_w_per_hz(CH) == pytest.approx(1e-14)
    # paper's SNR at 1 m with P = 1 W: 1e-5 / (2e6 * 1e-14) = 500
    assert physics.snr(1.0, 1.0, CH) == pytest.approx(500.0)
    c = physics.distance_factor(1.0, 1.0, CH)
    assert c == pytest.approx(500 / 501)
    assert physics.voi_of_x(0.5, CH.bandwidth_hz) == pytest.approx(2e6)


def test_an_array_gets_the_same_bits_as_each_element_through_libm():
    """physics.voi takes its logarithms and exponentials from libm (Python's math), not from
    numpy, whose SIMD versions on AVX-512 differ in the last bit: the same plan must simulate to
    the same value on every machine (VoI-Lib records values exactly). Each element of an array
    evaluation equals the formula evaluated in scalars with math, bit for bit."""
    rng = np.random.default_rng(11)
    aoi = rng.integers(1, 60, 4000).astype(float)
    q = rng.uniform(0.0, 8.0, 4000)
    rho = rng.uniform(0.0, 1.0, 4000)
    power = 0.1
    pg = power * physics.g0_linear(CH)
    got = physics.voi(aoi, q, rho, power, CH)

    def scalar(a: float, d: float, r: float) -> float:
        bn = CH.bandwidth_hz * physics.noise_w_per_hz(CH) * d**2
        a_log_rho = a * math.log(r)
        x = math.exp(a_log_rho + math.log(pg) - math.log(bn + pg))
        nats = -math.log1p(-x) if x <= 0.5 else math.log(bn + pg) - math.log(bn + pg * -math.expm1(a_log_rho))
        return CH.bandwidth_hz * nats / physics.LN2

    want = np.array([scalar(a, d, r) for a, d, r in zip(aoi, q, rho, strict=True)])
    assert np.array_equal(got, want)


def test_libm_edges_stay_quiet_and_keep_their_values():
    """Edges, with no warning: rho = 0 (log 0, which numpy's log warned about), ages below 0 with
    a small rho (overflow, tabulated and masked by models/uploads.py), nan; and voi_of_x bit for
    bit against math."""
    aoi = np.array([[-40.0], [1.0], [7.0]])
    rho = np.array([0.0, 1e-300, 0.3, 1.0, np.nan])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        v = physics.voi(aoi, 1.5, rho, 1e9, CH)
    assert v.shape == (3, 5)
    assert (v[1:, 0] == 0.0).all() and np.isnan(v[:, 4]).all()  # rho = 0: nothing left at ages >= 1
    assert (v[1:, 1:4] >= 0).all() and np.isfinite(v[1:, 1:4]).all()
    assert not np.isfinite(v[0, :3]).any()  # age -40 with rho < 1: overflow, no value (the tables mask it)
    x = np.random.default_rng(3).uniform(0.0, 1.0, 500)
    want = np.array([-CH.bandwidth_hz * math.log1p(-t) / physics.LN2 for t in x])
    assert np.array_equal(physics.voi_of_x(x, CH.bandwidth_hz), want)
    assert isinstance(physics.voi_of_x(0.25, CH.bandwidth_hz), float)


def test_the_compiled_loop_gives_pythons_libm_bits():
    """Large arrays take libm's log, log1p, exp and expm1 from a compiled loop (voiopt.runtime.libm),
    about 20 ns an element against a few hundred through Python's math (valuing a plan of 10^6
    slots took 4 to 5 s after the stop rule had fired). Every element, edges included (zeros of
    both signs, -1, infinities, nan, subnormals, overflow), must have the bits of physics'
    wrappers around Python's math."""
    from voiopt.runtime import libm

    rng = np.random.default_rng(5)
    edges = [0.0, -0.0, 1.0, -1.0, math.inf, -math.inf, math.nan, 5e-324, -5e-324, 1e-300, 709.78, 709.79, 710.0,
             -745.1, -746.0, -1 + 2**-53, -1 - 2**-52, -0.5, 0.5, 1e308, -1e308]
    x = np.concatenate([edges, rng.choice([-1.0, 1.0], 20_000) * 10.0 ** rng.uniform(-320, 308, 20_000),
                        rng.uniform(-2.0, 2.0, 20_000), -rng.uniform(0, 800, 4_999)])  # 45,020 = 9,004 x 5
    for f, code in ((physics._log, libm.LOG), (physics._log1p, libm.LOG1P), (physics._exp, libm.EXP),
                    (physics._expm1, libm.EXPM1)):
        want = np.fromiter(map(f, x.tolist()), float, x.size)
        got = libm.apply(code, x.reshape(-1, 5)).reshape(-1)
        assert np.array_equal(got.view(np.int64), want.view(np.int64)), f.__name__


def test_a_large_array_is_valued_with_the_same_bits_either_way(monkeypatch):
    """physics.voi of an array large enough for the compiled loop equals, bit for bit, the same
    call with every element taken through Python's math."""
    rng = np.random.default_rng(9)
    n = physics.COMPILED_FROM + 7
    aoi = rng.integers(1, 10**6, n).astype(float)
    q = rng.uniform(0.0, 8.0, n)
    rho = rng.uniform(0.0, 1.0, n)
    assert physics.compiled(n)
    fast = physics.voi(aoi, q, rho, 0.1, CH)
    monkeypatch.setattr(physics, "compiled", lambda size: False)
    slow = physics.voi(aoi, q, rho, 0.1, CH)
    assert np.array_equal(fast.view(np.int64), slow.view(np.int64))


def test_where_numba_vectorises_through_svml_the_python_path_is_kept(monkeypatch):
    from voiopt.runtime import libm

    monkeypatch.setattr(libm, "USING_SVML", True)
    assert not physics.compiled(physics.COMPILED_FROM)
    assert libm.apply(libm.LOG, np.ones(3)) is None
