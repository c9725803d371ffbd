"""Linearised vibration of a real reduced beam (gmsh + scikit-fem, clamped modes) on a
hinge with a rotational spring vs the Euler-Bernoulli characteristic equation."""

from __future__ import annotations

import numpy as np
import pytest
from dyn2_models import BEAM, fe_beam
from test_linearize import _hinged_beam_frequencies

from pipeline.dynamics import System
from pipeline.dynamics.forces import JointSpringDamper
from pipeline.dynamics.linearize import marker_motion, vibration_modes
from pipeline.kinematics import Joint, build_mechanism, rigid_link

pytestmark = pytest.mark.gmsh


def test_fe_beam_on_hinge_spring_frequencies_within_1_percent(tmp_path):
    _, body, link = fe_beam(tmp_path)
    k_r = 5.0e3
    mech = build_mechanism([rigid_link("ground"), link],
                           [Joint("hinge", "revolute", "ground", "body", "beam", "body")])
    system = System(mech, {"beam": body}, [0.0, 0.0, 0.0],
                    forces=[JointSpringDamper("k", "hinge.theta", stiffness=k_r)])
    modes = vibration_modes(system, np.zeros(mech.n))
    tip = marker_motion(system, modes, "beam", "tip")
    in_plane = np.abs(tip[1]) > np.abs(tip[2])  # hinge plane: tip moves along y
    f = modes.omega[in_plane][:3]
    ref = _hinged_beam_frequencies(BEAM["L"], BEAM["E"] * BEAM["I"], BEAM["rho"] * BEAM["A"],
                                   k_r, 3)
    err = f / ref - 1
    print("\nFE hinged beam: omega", np.round(f, 4), "EB", np.round(ref, 4), "rel", err)
    assert np.all(np.abs(err) < 1e-2)
    assert np.count_nonzero(in_plane) == 5  # hinge + 4 in-plane clamped modes
