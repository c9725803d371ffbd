"""Small systems for the force, statics, kinetostatics and linearisation tests.

- :func:`spatial_chain`: a spatial open chain with a flexible link (random-state
  virtual-work checks);
- :func:`eb_cantilever`: hand-made modal data of a clamped Euler-Bernoulli beam
  from the closed-form mode shapes (numerical quadrature of C, C', C'');
- :func:`rigid_bar`: BodyMass of a slender uniform bar along x.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "kinematics"))

from pipeline.dynamics import BodyMass
from pipeline.kinematics import Joint, build_mechanism, flexible_link, rigid_link
from pipeline.kinematics.rotations import homogeneous, rot_x, rot_y, translation

T = translation


def spatial_chain():
    """ground -R(z)- L1 -R(x')- L2 (flexible, 2 modes) -P(z'')- L3; markers on each link."""
    phi_tip = np.array([[0.0, 0.05, 0.01], [0.02, 0.0, -0.04]])
    psi_tip = np.array([[0.0, 0.0, 0.3], [0.1, -0.2, 0.0]])
    phi_mid = 0.4 * phi_tip
    psi_mid = np.array([[0.0, 0.1, 0.2], [0.05, 0.0, 0.1]])
    links = [
        rigid_link("ground", {"anchor": T([0.3, -0.2, 0.5])}),
        rigid_link("L1", {"ax": homogeneous(rot_y(np.pi / 2), [0.0, 0.0, 0.4]),
                          "m1": homogeneous(rot_x(0.3), [0.1, 0.2, 0.0])}),
        flexible_link("L2", {"tip": (homogeneous(rot_x(-0.4), [0.0, 0.1, 0.9]), phi_tip, psi_tip),
                             "mid": (T([0.05, 0.0, 0.45]), phi_mid, psi_mid)}),
        rigid_link("L3", {"m3": homogeneous(rot_y(0.7), [0.2, 0.1, 0.05])}),
    ]
    joints = [Joint("J1", "revolute", "ground", "body", "L1", "body"),
              Joint("J2", "revolute", "L1", "ax", "L2", "body"),
              Joint("J3", "prismatic", "L2", "tip", "L3", "body")]
    return build_mechanism(links, joints)


def rigid_bar(mass: float, length: float) -> BodyMass:
    """Uniform slender bar from the body origin along +x (inertia mL^2/12 about y, z)."""
    i = mass * length**2 / 12.0
    return BodyMass.rigid(mass, [0.5 * length, 0.0, 0.0], np.diag([1e-9 * i, i, i]))


EB_ROOTS = np.array([1.875104068711961, 4.694091132974175, 7.854757438237613,
                     10.99554073487547, 14.13716839104647, 17.27875953208824])


def eb_cantilever(length: float, EI: float, rho_A: float, n_modes: int, n_quad: int = 400):
    """Clamped-free EB beam along body x bending in body y: (BodyMass, tip phi, tip psi).

    Modes are the closed-form shapes w_a(x), mass-normalised by Gauss quadrature;
    C, C'_a, C''_ab are the integrals of DESIGN §2 with rho A dx; K = diag(omega^2),
    omega_a = (beta_a L)^2 sqrt(EI / (rho A L^4)).
    """
    xg, wg = np.polynomial.legendre.leggauss(n_quad)
    x = 0.5 * length * (xg + 1.0)
    w = 0.5 * length * wg * rho_A
    lam = EB_ROOTS[:n_modes] / length
    shapes, slopes_tip, tips = [], [], []
    for b in lam:
        s = (np.cosh(b * length) + np.cos(b * length)) / (np.sinh(b * length) + np.sin(b * length))

        def wfun(xx, b=b, s=s):
            return np.cosh(b * xx) - np.cos(b * xx) - s * (np.sinh(b * xx) - np.sin(b * xx))

        def dwfun(xx, b=b, s=s):
            return b * (np.sinh(b * xx) + np.sin(b * xx) - s * (np.cosh(b * xx) - np.cos(b * xx)))

        norm = np.sqrt(np.sum(w * wfun(x) ** 2))
        shapes.append(wfun(x) / norm)
        tips.append(wfun(length) / norm)
        slopes_tip.append(dwfun(length) / norm)
    rbar = np.stack([x, 0 * x, 0 * x, 1 + 0 * x])              # (4, g)
    phib = [np.stack([0 * x, s, 0 * x, 0 * x]) for s in shapes]  # (4, g) each
    C = (rbar * w) @ rbar.T
    Cp = np.array([(rbar * w) @ p.T for p in phib])
    Cpp = np.array([[(pa * w) @ pb.T for pb in phib] for pa in phib])
    omega = lam**2 * np.sqrt(EI / rho_A)
    body = BodyMass(C=C, Cp=Cp, Cpp=Cpp, stiffness=np.diag(omega**2),
                    damping=np.zeros((n_modes, n_modes)))
    phi_tip = np.array([[0.0, t, 0.0] for t in tips])
    psi_tip = np.array([[0.0, 0.0, s] for s in slopes_tip])
    return body, phi_tip, psi_tip, omega


BEAM_YAML = """\
name: beam
geometry:
  type: beam
  points: [[0, 0, 0], [{L}, 0, 0]]
  vertex_names: [root, tip]
  element_size: {h}
material: {{E: {E}, nu: 0.3, rho: {rho}}}
sections:
  - {{A: {A}, Iy: {I}, Iz: {I}, J: {J}, members: [0]}}
interfaces:
  - name: root
    selector: {{type: nearest, point: [0, 0, 0]}}
    z_axis: [0, 0, 1]
  - name: tip
    selector: {{type: nearest, point: [{L}, 0, 0]}}
    z_axis: [0, 0, 1]
reference: root
modes: {{count: {m}}}
"""

#: Uniform steel beam of the FE tests: L m, E Pa, rho kg/m^3, A m^2, I m^4.
BEAM = {"L": 2.0, "E": 2.1e11, "rho": 7850.0, "A": 1.0e-3, "I": 2.0e-7}


def fe_beam(folder: Path, n_modes: int = 8, element_size: float = 0.05):
    """Real reduced beam link (gmsh line mesh -> skfem Hermite beam -> clamped modes at
    'root' -> invariants) through the link-spec route: (ReducedLink, BodyMass, Link)."""
    from pipeline.dynamics.bodies import body_from_reduced, link_from_reduced
    from pipeline.invariants.reduce import reduce_link
    from pipeline.workflow.link_build import link_request
    from pipeline.workflow.link_spec import load_link_spec

    path = folder / "beam.yaml"
    path.write_text(BEAM_YAML.format(h=element_size, m=n_modes, J=2 * BEAM["I"], **BEAM))
    request, _ = link_request(load_link_spec(path), folder)
    reduced = reduce_link(request)
    return reduced, body_from_reduced(reduced), link_from_reduced(reduced)
