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
