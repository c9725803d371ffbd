"""A pressure-dependent bulk modulus: oil with entrained air (issue 27, item 1).

The model (pipeline.dynamics.forces.hydraulics): a volume fraction alpha of undissolved
air at atmospheric pressure p0, compressed isothermally beside oil of bulk modulus beta,
gives the mixture's effective bulk modulus at absolute pressure P = p + p0

    beta_e(P) = (1 + alpha p0 / P) / (1 / beta + alpha p0 / P^2).

References built here, independent of the package's equations:
- a closed chamber's pressure-volume law in closed form: with no flow,
  dP / beta_e(P) = -dV / V integrates to
      ln(V / V0) = -[(P - P0) / beta + ln(P / P0) - (1 + a / beta) ln((P + a) / (P0 + a))],
  a = alpha p0; every state of a run with the valve closed lies on it, side a and b;
- the oil columns' ring about the rest their pressures hold, at
  sqrt((beta_e(P_a) A_a^2 / V_a + beta_e(P_b) A_b^2 / V_b) / m), from linearisation;
- without air (alpha = 0) the constant-modulus element, unchanged.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_hydraulic_cylinder import AA, AB, BETA, MASS, PB0, S0, STROKE, VA0, VB0, G, _lift

from pipeline.core.errors import ConfigError
from pipeline.solver import simulate

P_ATM = 101325.0
AIR = 0.02  # 2 % air by volume at atmospheric pressure: soft at low pressure


def beta_e(p_gauge, alpha=AIR):
    P = np.asarray(p_gauge) + P_ATM
    return (1.0 + alpha * P_ATM / P) / (1.0 / BETA + alpha * P_ATM / P ** 2)


def log_volume_ratio(p, p0, alpha=AIR):
    """ln(V / V0) of a closed chamber taken from gauge pressure p0 to p (module
    docstring)."""
    P, P0, a = p + P_ATM, p0 + P_ATM, alpha * P_ATM
    return -((P - P0) / BETA + np.log(P / P0) - (1.0 + a / BETA) * np.log((P + a) / (P0 + a)))


def _closed_fall(step, air=0.0):
    pa0, pb0 = 5e5, 20e5  # p_a far below the 21 bar that holds the mass: it sinks
    system, _ = _lift(0.0, initial_pressures=(pa0, pb0), air_content=air)
    te = np.linspace(0.0, 0.2, 401)
    r = simulate(system, np.array([S0]), np.zeros(1), (0.0, 0.2), te,
                 method="generalized_alpha", step=step, progress=False, rtol=1e-4, atol=1e-7)
    s = r.q[:, 0]
    va, vb = VA0 + AA * s, VB0 + AB * (STROKE - s)
    ln_a, ln_b = np.log(va / va[0]), np.log(vb / vb[0])
    gap = max(np.abs(ln_a - log_volume_ratio(r.state("lift.p_a"), pa0, air)).max()
              / np.abs(ln_a).max(),
              np.abs(ln_b - log_volume_ratio(r.state("lift.p_b"), pb0, air)).max()
              / np.abs(ln_b).max())
    return r, S0 - s.min(), gap


def test_a_closed_chamber_follows_its_closed_form_pressure_volume_law():
    """Valve closed, released from pressures that do not hold the mass: it sinks onto its
    oil columns, much softer with the air at these pressures, and rings; every output's
    pressures are the closed form's for its chamber volumes, to the integration's error
    (second order in the step: 8.5e-6, 2.1e-6 measured)."""
    _, _, gap_coarse = _closed_fall(5e-5, AIR)
    r, sink, gap = _closed_fall(2.5e-5, AIR)
    assert r.verdict == "ok", r.report
    assert gap < 4e-6 and gap_coarse / gap > 3.5, (gap_coarse, gap)
    # the same chamber without air sinks less than half as deep, on its own law
    _, sink_oil, gap_oil = _closed_fall(2.5e-5)
    assert sink > 1e-3 and sink_oil < 0.5 * sink, (sink, sink_oil)
    assert gap_oil < 4e-6, gap_oil


def test_the_linearised_frequency_uses_the_effective_modulus_at_the_held_pressures():
    from pipeline.dynamics.linearize import vibration_modes

    system, cyl = _lift(0.0, air_content=AIR, initial_pressures=("hold", PB0))
    modes = vibration_modes(system, np.array([S0]))
    pa = (MASS * G + PB0 * AB) / AA
    np.testing.assert_allclose(modes.model.z, [pa, PB0], rtol=1e-12)
    va, vb = VA0 + AA * S0, VB0 + AB * (STROKE - S0)
    k = beta_e(pa) * AA ** 2 / va + beta_e(PB0) * AB ** 2 / vb
    assert k < 0.8 * BETA * (AA ** 2 / va + AB ** 2 / vb)  # the air matters here
    assert cyl.oil_stiffness(S0, (pa, PB0)) == pytest.approx(k, rel=1e-12)
    ring = np.flatnonzero(modes.frequencies_hz > 0)
    assert ring.size == 1
    assert abs(modes.omega[ring[0]] / np.sqrt(k / MASS) - 1.0) < 1e-6


def test_no_air_is_the_constant_modulus():
    _, cyl = _lift(0.0, air_content=0.0)
    assert cyl.oil_stiffness(S0) == pytest.approx(
        BETA * (AA ** 2 / (VA0 + AA * S0) + AB ** 2 / (VB0 + AB * (STROKE - S0))), rel=1e-15)


@pytest.mark.parametrize("value", [-0.01, 1.0, float("nan"), "some"])
def test_a_bad_air_content_is_refused(value):
    with pytest.raises(ConfigError, match="air_content: expected"):
        _lift(0.0, air_content=value)


# ---------------------------------------------------------------- the air dissolving
P_DIS = 15e5  # Pa gauge: all the air dissolved from 15 bar up


def undissolved(p_gauge):
    """The air's undissolved share: 1 up to atmospheric, 0 from P_DIS, a cubic with zero
    slope at both ends between (the model of pipeline.dynamics.forces.hydraulics)."""
    s = np.clip(np.asarray(p_gauge, dtype=float) / P_DIS, 0.0, 1.0)
    return 1.0 - s * s * (3.0 - 2.0 * s)


def mixture_volume(p_gauge, alpha=AIR):
    """Volume of the oil (1, its own compliance 1 / beta apart) and of the air left
    undissolved, compressed isothermally: 1 + alpha x(p) p0 / P."""
    return 1.0 + alpha * undissolved(p_gauge) * P_ATM / (np.asarray(p_gauge) + P_ATM)


def beta_dissolving(p_gauge, alpha=AIR):
    """V / (-dV/dp) of the mixture, dV/dp of the air by central differences (1 Pa)."""
    p = np.asarray(p_gauge, dtype=float)
    dv = (mixture_volume(p + 1.0, alpha) - mixture_volume(p - 1.0, alpha)) / 2.0
    return mixture_volume(p, alpha) / (1.0 / BETA - dv)


def test_the_dissolving_airs_modulus_is_the_mixtures_volume_law():
    """beta_e from the element (its oil stiffness at equal pressures) against V / (-dV/dp)
    of the mixture by differences: below atmospheric the undissolved law, across the band
    softer still (the air going into solution), from P_DIS up the oil's own beta; no
    jump at either end of the band."""
    _, cyl = _lift(0.0, air_content=AIR, air_dissolved_pressure=P_DIS)
    va, vb = VA0 + AA * S0, VB0 + AB * (STROKE - S0)
    area = AA ** 2 / va + AB ** 2 / vb
    p = np.array([-0.5e5, -1.0, 1.0, 1e5, 4e5, 7.5e5, 12e5, P_DIS - 1.0, P_DIS + 1.0, 50e5])
    got = np.array([cyl.oil_stiffness(S0, (x, x)) / area for x in p])
    ref = beta_dissolving(p)
    np.testing.assert_allclose(got, ref, rtol=1e-6)  # (the differences' own error)
    assert got[-1] == BETA and got[-2] / BETA > 1.0 - 1e-6
    # continuous at atmospheric pressure: over its 2 Pa, the undissolved law's own change
    # and the band's first 1 Pa (2.7e-7; a share falling linearly would jump by 6 %)
    assert abs(got[2] / got[1] - beta_e(1.0) / beta_e(-1.0)) < 1e-6
    assert got[4] < beta_e(4e5) * 0.9  # dissolving: softer than the undissolved law


def _compliance_dissolving(p_gauge, alpha=AIR):
    """1 / beta_e = (1 / beta - dV/dp) / V with dV/dp = alpha p0 (x' / P - x / P^2) of the
    volume law, x' = -6 s (1 - s) / P_DIS in the band (the product rule by hand)."""
    P = p_gauge + P_ATM
    s = min(max(p_gauge / P_DIS, 0.0), 1.0)
    dx = -6.0 * s * (1.0 - s) / P_DIS
    dv = alpha * P_ATM * (dx / P - undissolved(p_gauge) / P ** 2)
    return (1.0 / BETA - dv) / mixture_volume(p_gauge, alpha)


def _log_volume_ratio_dissolving(p, p0):
    """-int_p0^p dp / beta_e, by scipy's quad."""
    from scipy.integrate import quad

    return -quad(_compliance_dissolving, p0, p, points=[0.0, P_DIS], epsabs=0.0,
                 epsrel=1e-13, limit=200)[0]


def test_a_closed_chamber_with_the_air_dissolving_follows_its_volume_law():
    """Valve closed, the mass released onto its oil columns: p_a swings between 5 and 40
    bar, through the dissolving band; every output's (p, V) of chamber a lies on
    ln(V / V0) = -int dp / beta_e (the volume law's modulus, by quadrature), to the
    integration's error, second order in the step (from 10 us: the band's soft oil and
    its kinks in dbeta_e/dp leave coarser steps short of it); sealed_pressure inverts that
    law."""
    pa0, pb0 = 5e5, 20e5
    te = np.linspace(0.0, 0.1, 41)
    gaps = []
    for step in (1e-5, 5e-6):
        system, cyl = _lift(0.0, initial_pressures=(pa0, pb0), air_content=AIR,
                            air_dissolved_pressure=P_DIS)
        r = simulate(system, np.array([S0]), np.zeros(1), (0.0, 0.1), te,
                     method="generalized_alpha", step=step, progress=False, rtol=1e-4,
                     atol=1e-7)
        pa = r.state("lift.p_a")
        assert pa.min() < 6e5 and pa.max() > 2 * P_DIS  # through the band
        va = VA0 + AA * r.q[:, 0]
        ln = np.log(va / va[0])
        law = np.array([_log_volume_ratio_dissolving(x, pa0) for x in pa])
        gaps.append(np.abs(ln - law).max() / np.abs(ln).max())
    assert r.verdict == "ok", r.report
    print("dissolving air, chamber a against its volume law:", gaps)
    assert gaps[1] < 2e-6 and gaps[0] / gaps[1] > 3.0, gaps
    for ratio in (0.999, 0.99, 1.01):
        p = cyl.sealed_pressure(pa0, ratio)
        assert abs(_log_volume_ratio_dissolving(p, pa0) - np.log(ratio)) < 1e-9 * abs(
            np.log(ratio)), (ratio, p)


@pytest.mark.parametrize("kw, match", [
    ({"air_content": AIR, "air_dissolved_pressure": -1e5},
     "air_dissolved_pressure: expected a gauge pressure > 0 Pa"),
    ({"air_dissolved_pressure": 10e5}, "air_dissolved_pressure: there is no air to dissolve"),
])
def test_a_bad_dissolving_pressure_is_refused(kw, match):
    with pytest.raises(ConfigError, match=match):
        _lift(0.0, **kw)
