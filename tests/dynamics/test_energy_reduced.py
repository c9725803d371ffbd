"""Dynamics on real reduced links (gmsh + scikit-fem bars): BodyMass/Link from a
ReducedLink, modal damping, and energy conservation of a short run."""

from __future__ import annotations

import numpy as np
import pytest
from eom_models import reduced_bar_pendulum

from pipeline.core.errors import ConfigError
from pipeline.dynamics.bodies import body_from_reduced, link_from_reduced
from pipeline.kinematics import evaluate_tree
from pipeline.solver import simulate


@pytest.fixture(scope="module")
def pendulum(tmp_path_factory):
    return reduced_bar_pendulum(tmp_path_factory.mktemp("bars"), n_modes=2)


@pytest.mark.gmsh
def test_body_and_link_from_reduced(pendulum):
    system, red = pendulum
    b = body_from_reduced(red, modes=[1], damping_ratios=[0.03])
    w = 2 * np.pi * red.frequencies_hz[1]
    assert b.n_modes == 1 and np.allclose(b.stiffness, red.modal_stiffness[1, 1])
    assert np.isclose(b.damping[0, 0], 2 * 0.03 * w * red.modal_mass[1, 1], rtol=1e-9)
    ray = body_from_reduced(red, rayleigh=(0.5, 1e-4))
    assert np.allclose(ray.damping, 0.5 * red.modal_mass + 1e-4 * red.modal_stiffness)
    # the attached tip pin moves with the tip interface: same origin, same rotation
    link = link_from_reduced(red, frames={"tp": ("tip", np.eye(4))})
    assert np.array_equal(link.frame("tp").phi, link.frame("tip").phi)
    assert np.array_equal(link.frame("tp").psi, link.frame("tip").psi)
    # each bending mode keeps its plane: the mesh's round-off across it (1e-6) is gone
    assert np.allclose(link.frame("tip").phi, red.frame("tip").phi, rtol=0, atol=1e-5)
    # bar tip at 1 m along -x when horizontal, in the pipeline's tree
    A = evaluate_tree(system.mechanism, np.zeros(system.mechanism.n)).A
    assert np.allclose(A[2][:3, 3], [-1.0, 0.0, 0.0], atol=1e-12)
    with pytest.raises(ConfigError, match="modes"):
        body_from_reduced(red, modes=[5])
    with pytest.raises(ConfigError, match="ratios"):
        body_from_reduced(red, damping_ratios=[0.1])


@pytest.mark.gmsh
def test_reduced_bar_pendulum_conserves_energy(pendulum):
    system, _ = pendulum
    q0 = np.zeros(system.mechanism.n)
    r = simulate(system, q0, q0, (0.0, 0.3), np.linspace(0, 0.3, 31), rtol=1e-9, atol=1e-9,
                 progress=False)
    assert r.success, r.message
    assert np.abs(r.q[:, 2:]).max() > 1e-6  # gravity and the swing excite the modes
    E = r.energies["total"]
    assert np.abs(E - E[0]).max() < 1e-6 * np.abs(r.energies["kinetic"]).max()
