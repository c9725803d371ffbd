"""Statics on a real reduced link (gmsh beam mesh, scikit-fem Hermite beam, clamped
modes, invariants): cantilever tip deflection under gravity vs qL^4/8EI and under a
tip load vs PL^3/3EI."""

from __future__ import annotations

import numpy as np
import pytest
from dyn2_models import BEAM, fe_beam

from pipeline.dynamics import System
from pipeline.dynamics.forces import PointForce
from pipeline.dynamics.statics import static_equilibrium
from pipeline.kinematics import Joint, build_mechanism, rigid_link

pytestmark = pytest.mark.gmsh
G = 9.81


@pytest.fixture(scope="module")
def beam(tmp_path_factory):
    return fe_beam(tmp_path_factory.mktemp("beam"))


def _tip_z(beam, gravity, tip_load):
    _, body, link = beam
    mech = build_mechanism([rigid_link("ground"), link],
                           [Joint("clamp", "fixed", "ground", "body", "beam", "body")])
    forces = [PointForce("P", ("beam", "tip"), (0.0, 0.0, -tip_load))] if tip_load else []
    system = System(mech, {"beam": body}, [0.0, 0.0, -gravity], forces=forces)
    res = static_equilibrium(system, np.zeros(mech.n))
    assert res.success, res.message
    return float(res.q @ link.frame("tip").phi[:, 2])


def test_fe_cantilever_under_gravity_matches_qL4_over_8EI(beam):
    L, EI = BEAM["L"], BEAM["E"] * BEAM["I"]
    ref = -BEAM["rho"] * BEAM["A"] * G * L**4 / (8 * EI)
    w = _tip_z(beam, G, 0.0)
    print(f"\nFE cantilever, gravity: tip {w:.6e} m vs {ref:.6e} m ({w / ref - 1:.2e})")
    assert w == pytest.approx(ref, rel=1e-2)


def test_fe_cantilever_tip_load_matches_PL3_over_3EI(beam):
    L, EI, P = BEAM["L"], BEAM["E"] * BEAM["I"], 200.0
    ref = -P * L**3 / (3 * EI)
    w = _tip_z(beam, 0.0, P)
    print(f"\nFE cantilever, tip load: tip {w:.6e} m vs {ref:.6e} m ({w / ref - 1:.2e})")
    assert w == pytest.approx(ref, rel=1e-2)
