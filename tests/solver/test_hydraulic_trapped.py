"""Statics with trapped oil (issue 27, item 4): a closed-centre valve seals both chambers,
so their pressures follow the stroke (the oil compressed or relieved) and the statics finds
the stroke where the compressed oil holds the load.

References built here: the lift of test_hydraulic_cylinder.py released from pressures that
do not hold its 500 kg; each chamber's pressure from its oil law, p = p0 + beta ln(V0 / V)
(and, with entrained air, the closed-form law of test_hydraulic_air.py inverted by
brentq), and the force balance p_a A_a - p_b A_b = m g solved for the stroke by brentq.
A dynamic run from that pose and those pressures stays there.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_hydraulic_air import AIR, P_ATM, log_volume_ratio
from test_hydraulic_cylinder import AA, AB, BETA, MASS, S0, STROKE, VA0, VB0, G, _lift

from pipeline.core.errors import ConfigError
from pipeline.dynamics import static_equilibrium
from pipeline.solver import simulate

P0 = (10e5, 10e5)  # Pa: 10 bar each side holds 0.72 of the load: the mass sinks onto its oil


def _pressure(p0, ratio, air):
    """The pressure of oil taken from p0 to the volume ratio V / V0, sealed."""
    if not air:
        return p0 - BETA * np.log(ratio)
    return brentq(lambda p: log_volume_ratio(p, p0, air) - np.log(ratio), 1e-3 - P_ATM,
                  p0 + 100 * BETA, xtol=1e-9, rtol=1e-14)


def _reference(air):
    def pressures(s):
        pa = _pressure(P0[0], (VA0 + AA * s) / (VA0 + AA * S0), air)
        pb = _pressure(P0[1], (VB0 + AB * (STROKE - s)) / (VB0 + AB * (STROKE - S0)), air)
        return pa, pb

    def balance(s):
        pa, pb = pressures(s)
        return pa * AA - pb * AB - MASS * G

    s = brentq(balance, S0 - 0.05, S0, xtol=1e-15)
    return s, pressures(s)


@pytest.mark.parametrize("air", [0.0, AIR])
def test_the_trapped_oil_holds_the_load_where_its_closed_form_says(air):
    system, _ = _lift(0.0, air_content=air, initial_pressures=P0)
    s_ref, p_ref = _reference(air)
    assert S0 - s_ref > (1e-4 if not air else 2.5e-4)  # it sank onto its oil (0.12, 0.28 mm)
    res = static_equilibrium(system, np.array([S0]), z=np.array(P0), trapped=True)
    assert res.success, res.message
    assert abs(res.q[0] - s_ref) < 1e-10, (res.q[0], s_ref)
    np.testing.assert_allclose(res.z, p_ref, rtol=1e-9)
    # a run from there, with those pressures, stays at rest
    there, _ = _lift(0.0, air_content=air, initial_pressures=tuple(res.z))
    r = simulate(there, res.q, np.zeros(1), (0.0, 0.05), np.linspace(0.0, 0.05, 6),
                 method="generalized_alpha", step=1e-4, progress=False, rtol=1e-5,
                 atol=1e-9)
    assert r.verdict == "ok", r.report
    assert np.abs(r.q[:, 0] - res.q[0]).max() < 1e-9


def test_held_states_stay_held_without_trapped():
    """Without ``trapped`` the states are held as given: the statics finds no pose where
    10 bar holds 500 kg (the stroke's reach does not change the pressures)."""
    system, _ = _lift(0.0, initial_pressures=P0)
    res = static_equilibrium(system, np.array([S0]), z=np.array(P0))
    assert not res.success
    np.testing.assert_array_equal(res.z, P0)


def test_an_open_valve_traps_nothing():
    system, _ = _lift(0.5, initial_pressures=P0)
    with pytest.raises(ConfigError, match="force element 'lift': trapped: its valve is open "
                                          r"at t = 0 s \(command 0\.5\)"):
        static_equilibrium(system, np.array([S0]), z=np.array(P0), trapped=True)
