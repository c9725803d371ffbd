"""Models for the equations-of-motion tests: point-cloud flexible links with
hand-made invariants, and hand-coded (independent) kinematics and kinetic energy.

A cloud link has points r_g (G, 3), masses m_g (G,) and random mode fields
phi (m, G, 3); its invariants are the sums of DESIGN §2. The hand-coded
kinematics below restate DESIGN §3 directly (Rz joints, first-order shape
matrix S(eta)) without the pipeline, and the kinetic energy is
T = 1/2 sum_g m_g |R_g'|^2 with R_g' by complex-step differentiation.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from pipeline.dynamics import BodyMass, System
from pipeline.kinematics import Joint, build_mechanism, flexible_link, rigid_link
from pipeline.kinematics.rotations import translation


@dataclass(frozen=True)
class Cloud:
    r: np.ndarray    # (G, 3) m
    m: np.ndarray    # (G,) kg
    phi: np.ndarray  # (k, G, 3) m per unit eta

    def body(self, stiffness=None, damping=None) -> BodyMass:
        k = self.phi.shape[0]
        rb = np.hstack([self.r, np.ones((len(self.m), 1))])
        pb = np.concatenate([self.phi, np.zeros((k, len(self.m), 1))], axis=2)
        C = np.einsum("g,gi,gj->ij", self.m, rb, rb)
        if k == 0:
            return BodyMass(C=C)
        Cp = np.einsum("g,gi,agj->aij", self.m, rb, pb)
        Cpp = np.einsum("g,agi,bgj->abij", self.m, pb, pb)
        K = np.zeros((k, k)) if stiffness is None else stiffness
        D = np.zeros((k, k)) if damping is None else damping
        return BodyMass(C=C, Cp=Cp, Cpp=Cpp, stiffness=K, damping=D)


def cloud(rng, length, n_modes, n_points=12, mass=2.0, amp=0.05) -> Cloud:
    """Points along x in [0, length] with a small cross-section spread, smooth random modes."""
    x = np.linspace(0.05 * length, length, n_points)
    r = np.column_stack([x, 0.04 * rng.standard_normal(n_points),
                         0.03 * rng.standard_normal(n_points)])
    m = mass / n_points * (0.5 + rng.random(n_points))
    s = x / length
    phi = np.zeros((n_modes, n_points, 3))
    for a in range(n_modes):  # bending-like shapes growing from the clamped end, plus noise
        c = rng.standard_normal(3)
        phi[a] = amp * (np.outer(s ** (a + 2), c) + 0.1 * rng.standard_normal((n_points, 3)))
    return Cloud(r, m, phi)


def frame_modes(rng, n_modes, amp=0.05):
    return amp * rng.standard_normal((n_modes, 3)), amp * rng.standard_normal((n_modes, 3))


# ----------------------------------------------------------------- hand-coded kinematics
def rz(x):
    c, s = np.cos(x), np.sin(x)
    z, o = 0.0 * x, 1.0 + 0.0 * x
    return np.array([[c, -s, z, z], [s, c, z, z], [z, z, o, z], [z, z, z, o]])


def shape(r0, phi, psi, eta):
    """First-order flexible shape matrix of a frame with identity undeformed rotation."""
    th = eta @ psi
    u = eta @ phi
    S = np.zeros((4, 4), dtype=np.result_type(eta, float))
    S[:3, :3] = np.eye(3) + np.array([[0, -th[2], th[1]], [th[2], 0, -th[0]],
                                      [-th[1], th[0], 0]])
    S[:3, 3] = r0 + u
    S[3, 3] = 1.0
    return S


def points(A, c: Cloud, eta):
    """(G, 3) global positions A (r_g + sum eta_a phi_a,g)."""
    p = c.r + (np.tensordot(eta, c.phi, axes=1) if c.phi.shape[0] else 0.0)
    return p @ A[:3, :3].T + A[:3, 3]


def kinetic(positions, masses, q, qd, eps=1e-30):
    """T = 1/2 sum m |R'|^2 with R' = Im R(q + i eps qd) / eps (exact to rounding)."""
    P = positions(q + 1j * eps * qd)
    T = 0.0
    for Pl, ml in zip(P, masses):
        v = Pl.imag / eps
        T += 0.5 * float(np.sum(ml[:, None] * v * v))
    return T


def potential(positions, masses, q, g):
    return -sum(float(np.sum(ml * (Pl @ g))) for Pl, ml in zip(positions(q), masses))


# ----------------------------------------------------------------- models
@dataclass(frozen=True)
class Model:
    system: System
    positions: object  # q -> list of (G_l, 3) point arrays (hand-coded)
    masses: list
    weights: list | None = None  # the points' masses in the potential, if not ``masses``

    @property
    def gravity_masses(self) -> list:
        return self.masses if self.weights is None else self.weights


def moving_mass(A, G, eta):
    """(8, 3) points holding, with the masses (8,) ``MOVING_MASSES``, the kinetic energy
    int rho (T' xb) . d(R u2)/dt of the rigid motion T = [R, p] with a second-order moving
    mass u2 (moments int rho xb_j u2 = S_j(eta), S = sum eta_a eta_b G_ab / 2 (4, 3),
    G (m, m, 4, 3)), and nothing else: sum_j (T' E_j) . (R S_j)' with E_j = e_j for the
    first moments (a direction: R e_j, not a body point) and the origin p for the mean,
    each product from a pair X_j +- R S_j with masses +-1/2 (|v + c|^2 - |v - c|^2 =
    4 v . c). Their weight is not physical: only the mean's pair has the potential
    -g . R S_3 (``MOVING_WEIGHTS``)."""
    S = 0.5 * np.einsum("abjk,a,b->jk", G, eta, eta)
    X = np.vstack([A[:3, :3].T, A[:3, 3]])  # R e_j (rows), p
    RS = S @ A[:3, :3].T
    return np.concatenate([X + RS, X - RS])


MOVING_MASSES = np.r_[0.5 * np.ones(4), -0.5 * np.ones(4)]
MOVING_WEIGHTS = np.r_[0, 0, 0, 0.5, 0, 0, 0, -0.5]


def flexible_double_pendulum(seed=0, n_modes=3, k_scale=200.0, zeta=None, g=9.81,
                             second_order=False):
    """Two flexible links in the x-y plane (gravity -y); joints about z.

    Coordinates: j1.theta, j2.theta, link1.eta1..m, link2.eta1..m. ``second_order``: each
    link also has random second-order mass moments (``second_order_moments``), held in
    the hand-coded positions by the points of :func:`moving_mass`.
    """
    rng = np.random.default_rng(seed)
    L1, L2 = 1.0, 0.8
    c1, c2 = cloud(rng, L1, n_modes, mass=2.0), cloud(rng, L2, n_modes, mass=1.5)
    phiB, psiB = frame_modes(rng, n_modes)
    phiC, psiC = frame_modes(rng, n_modes)
    bodies = {}
    for name, c in (("link1", c1), ("link2", c2)):
        Mm = np.einsum("g,agi,bgi->ab", c.m, c.phi, c.phi)
        K = k_scale * np.diag(np.diag(Mm)) * (1.0 + np.arange(n_modes)) ** 2 if n_modes else None
        D = None
        if zeta is not None and n_modes:
            w = np.sqrt(np.diag(K) / np.diag(Mm))
            D = np.diag(2.0 * zeta * w * np.diag(Mm))
        bodies[name] = c.body(K, D)
    hess = {}
    if second_order and n_modes:
        for name, body in bodies.items():
            # like a bending link's: its mass moves back along x (negative definite, of
            # the modal mass's size per metre), a little sideways
            size = np.trace(np.einsum("abii->ab", body.Cpp)) / n_modes
            P = rng.standard_normal((n_modes, n_modes))
            G = 0.02 * size * rng.standard_normal((n_modes, n_modes, 4, 3))
            G[:, :, 3, 0] = -0.5 * size * P @ P.T
            G[:, :, 0, 0] = -0.3 * size * P @ P.T  # in metres from the origin
            hess[name] = 0.5 * (G + G.transpose(1, 0, 2, 3))
            bodies[name] = replace(body, second_order_moments=hess[name])
    if n_modes:
        l1 = flexible_link("link1", {"B": (translation([L1, 0, 0]), phiB, psiB)})
        l2 = flexible_link("link2", {"C": (translation([L2, 0, 0]), phiC, psiC)})
    else:
        l1 = rigid_link("link1", {"B": translation([L1, 0, 0])})
        l2 = rigid_link("link2", {"C": translation([L2, 0, 0])})
    mech = build_mechanism([rigid_link("ground"), l1, l2], [
        Joint("j1", "revolute", "ground", "body", "link1", "body", (0.0,)),
        Joint("j2", "revolute", "link1", "B", "link2", "body", (0.0,))])
    system = System(mech, bodies, gravity=[0.0, -g, 0.0])
    m = n_modes

    def positions(q):
        e1, e2 = q[2:2 + m], q[2 + m:2 + 2 * m]
        A1 = rz(q[0])
        A2 = A1 @ shape(np.array([L1, 0, 0]), phiB, psiB, e1) @ rz(q[1])
        out = [points(A1, c1, e1), points(A2, c2, e2)]
        if hess:
            out += [moving_mass(A1, hess["link1"], e1), moving_mass(A2, hess["link2"], e2)]
        return out

    pairs = 2 if hess else 0
    return Model(system, positions, [c1.m, c2.m] + [MOVING_MASSES] * pairs,
                 [c1.m, c2.m] + [MOVING_WEIGHTS] * pairs)


def flexible_four_bar(seed=1, n_modes=3, a=1.0, b=2.2, c=2.0, d=2.5, second_order=False):
    """Four-bar (kin_models conventions) with a flexible coupler and cloud masses.

    Tree from ground: J2 -> crank, J1 -> rocker, J3 -> coupler; J4 is cut.
    Coordinates: J2, J3, J4, J1, coupler.eta1..m. ``second_order``: the coupler's frame B
    also has a random in-plane second-order translation (``Frame.hess``) and the coupler
    random second-order mass moments (the hand-coded positions do not follow them).
    """
    rng = np.random.default_rng(seed)
    cc = cloud(rng, a, 0, mass=1.0)
    cb = cloud(rng, b, n_modes, mass=3.0)
    cr = cloud(rng, c, 0, mass=2.0)
    phiB, psiB = frame_modes(rng, n_modes)
    phiB[:, 2] = psiB[:, :2] = 0.0  # in-plane loop frame motion: the loop stays planar
    Mm = np.einsum("g,agi,bgi->ab", cb.m, cb.phi, cb.phi)
    K = 500.0 * np.diag(np.diag(Mm)) * (1.0 + np.arange(n_modes)) ** 2
    T = translation
    hessB, moments = None, None
    if second_order and n_modes:
        hessB = 0.05 * rng.standard_normal((n_modes, n_modes, 3))
        hessB = hessB + hessB.transpose(1, 0, 2)
        hessB[..., 2] = 0.0
        moments = 0.02 * np.trace(Mm) * rng.standard_normal((n_modes, n_modes, 4, 3))
        moments = moments + moments.transpose(1, 0, 2, 3)
    coupler = (flexible_link("coupler", {"B": (T([b, 0, 0]), phiB, psiB, hessB)}) if n_modes
               else rigid_link("coupler", {"B": T([b, 0, 0])}))
    links = [rigid_link("ground", {"O4": T([d, 0, 0])}), rigid_link("crank", {"A": T([a, 0, 0])}),
             coupler,
             rigid_link("rocker", {"B": T([c, 0, 0])})]
    th2, th3, th4 = 1.2, 0.35, 1.5  # approximate assembly
    joints = [Joint("J2", "revolute", "ground", "body", "crank", "body", (th2,)),
              Joint("J3", "revolute", "crank", "A", "coupler", "body", (th3 - th2,)),
              Joint("J4", "revolute", "coupler", "B", "rocker", "B", (th4 - th3,)),
              Joint("J1", "revolute", "ground", "O4", "rocker", "body", (th4,))]
    mech = build_mechanism(links, joints)
    coupler_body = cb.body(K)
    if moments is not None:
        coupler_body = replace(coupler_body, second_order_moments=moments)
    system = System(mech, {"crank": cc.body(), "coupler": coupler_body, "rocker": cr.body()},
                    gravity=[0.0, -9.81, 0.0])

    def positions(q):
        eta = q[4:4 + n_modes]
        Ac = rz(q[0])
        Ab = Ac @ T([a, 0, 0]) @ rz(q[1])
        Ar = T([d, 0, 0]) @ rz(q[3])
        return [points(Ac, cc, eta[:0]), points(Ab, cb, eta), points(Ar, cr, eta[:0])]

    return Model(system, positions, [cc.m, cb.m, cr.m])


def reduced_bar_pendulum(folder, n_modes=4, zeta=None, L=1.0):
    """Double pendulum of two real reduced Al bars (gmsh + scikit-fem, P2 tets).

    Each bar (L x 0.03 x 0.015 m) has its body frame at the root interface,
    z along the bar; pin frames with z across the bar are attached at root and
    tip, so both joints turn about global z and the bars start horizontal
    (along -x) under gravity -y. Returns (system, reduced link).
    """
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from link_samples import write_bar

    from pipeline.dynamics.bodies import body_from_reduced, link_from_reduced
    from pipeline.kinematics.rotations import homogeneous, inverse, rot_y
    from pipeline.workflow.link_build import reduce_spec
    from pipeline.workflow.link_spec import load_link_spec

    spec = write_bar(folder, L=L, b=0.03, h=0.015, size=0.015, modes=n_modes)
    red = reduce_spec(load_link_spec(spec), folder, folder / "links")[0]
    pin = homogeneous(rot_y(np.pi / 2))
    tip_pin = inverse(red.frame("tip").pose) @ homogeneous(rot_y(np.pi / 2), [0.0, 0.0, L])
    extra = {"pin": ("root", pin), "tip_pin": ("tip", tip_pin)}
    zr = None if zeta is None else [zeta] * n_modes
    links = [rigid_link("ground")] + [link_from_reduced(red, name=nm, frames=extra)
                                      for nm in ("bar1", "bar2")]
    mech = build_mechanism(links, [
        Joint("j1", "revolute", "ground", "body", "bar1", "pin"),
        Joint("j2", "revolute", "bar1", "tip_pin", "bar2", "pin")])
    bodies = {nm: body_from_reduced(red, damping_ratios=zr) for nm in ("bar1", "bar2")}
    return System(mech, bodies, gravity=[0.0, -9.81, 0.0]), red
