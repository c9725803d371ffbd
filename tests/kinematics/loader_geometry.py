"""Planar geometry of the front-end loader of DESIGN §5 (seed Fig. 3.38).

The seed's machine is a Ford/New Holland L555 skid-steer loader (rated
operating capacity 1000 lb = 4.4482 kN) but gives no dimensions. Everything
here is an *estimate* of a plausible machine of that class; the reasoning and
the table are in ``docs/front_loader_geometry.md``.

Frames and units
----------------
Chassis frame: origin on the ground directly below the rear axle, x forward,
y to the left, z up; m, kg, N. The linkage moves in the x–z plane; every pin
axis is parallel to y. Points are given as (x, z) in the *reference
configuration*: arm fully lowered, bucket level on the ground, both
cylinders at the lengths :data:`REFERENCE_LIFT_LENGTH` and
:data:`REFERENCE_TILT_LENGTH`. Both sides of the machine (two arms, two lift
cylinders, ...) are lumped into one planar linkage: forces are totals.

3-D use: put every revolute joint's z axis along chassis −y, so that a
positive joint angle is counter-clockwise in the side view (x right, z up,
seen from −y). Put each prismatic (cylinder) joint's z axis along the
cylinder, from its base pin to its rod pin: the joint variable is then the
pin-to-pin length in m, with the barrel frame at the base pin and the rod
frame at the rod pin.

Run ``python tests/kinematics/loader_geometry.py`` to redraw
``docs/front_loader_geometry.png``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import fsolve

STEEL_RHO = 7850.0  # kg/m^3
G = 9.81  # m/s^2
RATED_LOAD_N = 4448.2  # 1000 lbf: the seed's bucket load

#: Reference-configuration points (x, z) in m, chassis frame.
POINTS: dict[str, tuple[float, float]] = {
    # chassis pins (rear top tower and side)
    "UCPT": (-0.50, 1.55),   # upper lift link - chassis
    "LCPT": (-0.43, 1.42),   # lower lift link - chassis
    "LLCPT": (-0.15, 0.95),  # lift cylinder base - chassis
    # lift arm pins
    "ULAPT": (0.00, 1.34),   # upper lift link - arm
    "LLAPT": (-0.18, 1.01),  # lower lift link - arm
    "ULCPT": (1.05, 0.85),   # lift cylinder rod - arm (lug on the front leg)
    "UTCPT": (1.05, 1.35),   # tilt cylinder base - arm (lug under the arm bend)
    "BKPT": (1.45, 0.22),    # bucket hinge pin at the arm tip
    # bucket
    "LTCPT": (1.55, 0.425),  # tilt cylinder rod - bucket (lug on the attach plate)
    "LOAD": (1.85, 0.30),    # centre of the rated load in the level bucket
    # shape-only points (drawing, mass properties)
    "ARM_BEND": (1.15, 1.32),
    "BUCKET_TOP_BACK": (1.50, 0.78),
    "BUCKET_HEEL": (1.55, 0.00),
    "BUCKET_EDGE": (2.12, 0.00),
    "BUCKET_LIP": (2.05, 0.50),
    "REAR_AXLE": (0.00, 0.35),
    "FRONT_AXLE": (0.95, 0.35),
}

#: Lift and tilt cylinder pin-to-pin lengths (m) in the reference configuration.
REFERENCE_LIFT_LENGTH = float(np.hypot(*np.subtract(POINTS["ULCPT"], POINTS["LLCPT"])))
REFERENCE_TILT_LENGTH = float(np.hypot(*np.subtract(POINTS["LTCPT"], POINTS["UTCPT"])))


@dataclass(frozen=True)
class Cylinder:
    """A hydraulic cylinder: barrel pinned at ``base``, rod pinned at ``rod_end``."""

    joint: str          # prismatic joint name
    base: str           # point name of the barrel pin
    rod_end: str        # point name of the rod pin
    min_length: float   # fully retracted pin-to-pin length, m
    max_length: float   # fully extended pin-to-pin length, m
    bore: float         # m (estimate, for pressures)
    rod: float          # rod diameter, m
    count: int          # cylinders lumped into this one (both sides)

    @property
    def stroke(self) -> float:
        return self.max_length - self.min_length


CYLINDERS: dict[str, Cylinder] = {
    # the retracted length is the reference one: the arm rests on its stops there
    "lift": Cylinder("LCYL", "LLCPT", "ULCPT", REFERENCE_LIFT_LENGTH,
                     REFERENCE_LIFT_LENGTH + 0.755, 0.050, 0.030, 2),
    "tilt": Cylinder("TCYL", "UTCPT", "LTCPT", 0.975, 1.410, 0.063, 0.035, 1),
}


@dataclass(frozen=True)
class Joint:
    """A joint between two links at a named point (axes: see module docstring)."""

    name: str
    type: str      # "revolute" | "prismatic"
    parent: str
    child: str
    point: str     # point where the joint frames sit (the parent's frame for prismatic)


#: Joints, parent before child; the tree from ground is listed first, cut joints last.
JOINTS: tuple[Joint, ...] = (
    Joint("CHASSIS_X", "prismatic", "ground", "chassis", "REAR_AXLE"),  # along chassis x
    Joint("LCPT", "revolute", "chassis", "lower_link", "LCPT"),
    Joint("LLAPT", "revolute", "lower_link", "lift_arm", "LLAPT"),
    Joint("UCPT", "revolute", "chassis", "upper_link", "UCPT"),
    Joint("LLCPT", "revolute", "chassis", "lift_barrel", "LLCPT"),
    Joint("LCYL", "prismatic", "lift_barrel", "lift_rod", "LLCPT"),     # driven: lift length
    Joint("BKPT", "revolute", "lift_arm", "bucket", "BKPT"),
    Joint("UTCPT", "revolute", "lift_arm", "tilt_barrel", "UTCPT"),
    Joint("TCYL", "prismatic", "tilt_barrel", "tilt_rod", "UTCPT"),     # driven: tilt length
    # loop-closing joints
    Joint("ULAPT", "revolute", "upper_link", "lift_arm", "ULAPT"),
    Joint("ULCPT", "revolute", "lift_rod", "lift_arm", "ULCPT"),
    Joint("LTCPT", "revolute", "tilt_rod", "bucket", "LTCPT"),
)


@dataclass(frozen=True)
class Loop:
    """An independent loop as the seed lists it: joints in order around the loop."""

    name: str
    description: str
    joints: tuple[str, ...]


LOOPS: tuple[Loop, ...] = (
    Loop("bucket_position",
         "lift arm - bucket (BKPT) - tilt rod (LTCPT) - tilt cylinder (TCYL) - "
         "tilt barrel - arm (UTCPT): the tilt cylinder sets the bucket angle on the arm",
         ("BKPT", "LTCPT", "TCYL", "UTCPT")),
    Loop("lower_lifting",
         "chassis - lower link (LCPT) - arm (LLAPT) - lift rod (ULCPT) - lift cylinder "
         "(LCYL) - lift barrel - chassis (LLCPT): the lift cylinder drives the arm",
         ("LCPT", "LLAPT", "ULCPT", "LCYL", "LLCPT")),
    Loop("upper_position_control",
         "chassis - lower link (LCPT) - arm (LLAPT) - upper link (ULAPT) - chassis (UCPT): "
         "the four-bar that guides the arm",
         ("LCPT", "LLAPT", "ULAPT", "UCPT")),
)

#: Points carried by each link (joint points first; the first is its body frame).
LINK_POINTS: dict[str, tuple[str, ...]] = {
    "chassis": ("REAR_AXLE", "LCPT", "UCPT", "LLCPT", "FRONT_AXLE"),
    "lower_link": ("LCPT", "LLAPT"),
    "upper_link": ("UCPT", "ULAPT"),
    "lift_arm": ("LLAPT", "ULAPT", "ARM_BEND", "ULCPT", "UTCPT", "BKPT"),
    "bucket": ("BKPT", "LTCPT", "LOAD", "BUCKET_TOP_BACK", "BUCKET_HEEL", "BUCKET_EDGE",
               "BUCKET_LIP"),
    "lift_barrel": ("LLCPT",),
    "lift_rod": ("ULCPT",),
    "tilt_barrel": ("UTCPT",),
    "tilt_rod": ("LTCPT",),
}

#: The rated load: a vertical force (N) at point ``LOAD`` of the bucket.
BUCKET_LOAD = {"link": "bucket", "point": "LOAD", "force_xz": (0.0, -RATED_LOAD_N)}


# ----------------------------------------------------------------------------- masses
@dataclass(frozen=True)
class Member:
    """A straight steel member between two points: section area A (m²) at lateral
    offsets ``ys`` (m, one entry per side), or a plate strip of lateral ``width``."""

    p: str
    q: str
    area: float
    ys: tuple[float, ...] = (0.0,)
    width: float = 0.0


# Sections (estimates): arm 160 x 80 mm box of 8 mm plate (A = 3.58e-3 m²) per side,
# sides at y = +-0.70 m; links: one 100 x 25 mm flat bar per side; bucket: 1.52 m wide,
# 5 mm skin, 6 mm attach plate, 16 x 150 mm cutting edge; cylinders: barrel tube
# and solid rod, each half of the pin-to-pin length.
_ARM_Y = (-0.70, 0.70)
_BOX = 2 * (0.16 + 0.08) * 0.008 - 4 * 0.008**2
MEMBERS: dict[str, tuple[Member, ...]] = {
    "lift_arm": (Member("ULAPT", "ARM_BEND", _BOX, _ARM_Y),
                 Member("ARM_BEND", "BKPT", _BOX, _ARM_Y),
                 Member("LLAPT", "ULAPT", 2 * 0.012 * 0.20, _ARM_Y),     # rear gusset plate
                 Member("ARM_BEND", "UTCPT", 2 * 0.012 * 0.12, _ARM_Y),  # tilt lug plates
                 Member("ULCPT", "BKPT", 0.012 * 0.15, _ARM_Y)),         # cylinder lug
    "lower_link": (Member("LCPT", "LLAPT", 0.100 * 0.025, _ARM_Y),),
    "upper_link": (Member("UCPT", "ULAPT", 0.100 * 0.025, _ARM_Y),),
    "bucket": (Member("BUCKET_TOP_BACK", "BUCKET_HEEL", 0.006 * 1.52, width=1.52),
               Member("BUCKET_HEEL", "BUCKET_EDGE", 0.005 * 1.52, width=1.52),
               Member("BUCKET_EDGE", "BUCKET_EDGE", 0.016 * 0.150 * 1.52, width=1.52),  # volume
               Member("BUCKET_TOP_BACK", "BUCKET_LIP", 0.005 * 1.52, width=1.52),
               Member("BUCKET_HEEL", "BUCKET_LIP", 2 * 0.006 * 0.30, (-0.76, 0.76))),
}

_CYL_TUBE = {"lift": np.pi / 4 * (0.066**2 - 0.050**2), "tilt": np.pi / 4 * (0.080**2 - 0.063**2)}
# squared radii of gyration about the cylinder axis: tube (ro² + ri²)/2, solid rod r²/2
_CYL_K2 = {("lift", "barrel"): (0.033**2 + 0.025**2) / 2, ("lift", "rod"): 0.015**2 / 2,
           ("tilt", "barrel"): (0.040**2 + 0.0315**2) / 2, ("tilt", "rod"): 0.0175**2 / 2}
_CYL_ROD = {"lift": np.pi / 4 * 0.030**2, "tilt": np.pi / 4 * 0.035**2}


@dataclass(frozen=True)
class MassProps:
    """Mass (kg), centre of mass (3,) and inertia tensor about it (3, 3), chassis
    axes, reference configuration."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray


def _xyz(name_or_xz, y: float = 0.0) -> np.ndarray:
    x, z = POINTS[name_or_xz] if isinstance(name_or_xz, str) else name_or_xz
    return np.array([x, y, z])


def _members_props(members, segments=None) -> MassProps:
    """Sum thin rods / plate strips (inertia of each about its own centre + parallel axis)."""
    parts = []
    for m in members:
        for y in m.ys:
            a, b = _xyz(m.p, y), _xyz(m.q, y)
            L = np.linalg.norm(b - a)
            length = L if L > 0 else 1.0  # point-like member (p == q): ``area`` is its volume
            mass = STEEL_RHO * m.area * length
            u = (b - a) / L if L > 0 else np.zeros(3)
            ey = np.array([0.0, 1.0, 0.0])
            I0 = mass * L**2 / 12 * (np.eye(3) - np.outer(u, u))
            I0 += mass * m.width**2 / 12 * (np.eye(3) - np.outer(ey, ey))
            parts.append((mass, 0.5 * (a + b), I0))
    return _combine(parts)


def _combine(parts) -> MassProps:
    M = sum(p[0] for p in parts)
    c = sum(p[0] * p[1] for p in parts) / M
    I = np.zeros((3, 3))
    for m, r, I0 in parts:
        d = r - c
        I += I0 + m * (d @ d * np.eye(3) - np.outer(d, d))
    return MassProps(float(M), c, I)


def _cylinder_props(kind: str) -> dict[str, MassProps]:
    """Barrel (tube, base half) and rod (solid, rod half) at the reference lengths."""
    cyl = CYLINDERS[kind]
    a, b = _xyz(cyl.base), _xyz(cyl.rod_end)
    mid = 0.5 * (a + b)
    ys = (-0.70, 0.70) if cyl.count == 2 else (0.0,)
    out = {}
    for part, (p, q, area) in {"barrel": (a, mid, _CYL_TUBE[kind]),
                               "rod": (mid, b, _CYL_ROD[kind])}.items():
        pieces = []
        for y in ys:
            off = np.array([0.0, y, 0.0])
            L = np.linalg.norm(q - p)
            u = (q - p) / L
            m = STEEL_RHO * area * L * 1.15  # +15 %: end eyes, glands, oil
            k2 = _CYL_K2[(kind, part)]
            uu = np.outer(u, u)
            I0 = m * (L**2 / 12 + k2 / 2) * (np.eye(3) - uu) + m * k2 * uu
            pieces.append((m, 0.5 * (p + q) + off, I0))
        out[f"{kind}_{part}"] = _combine(pieces)
    return out


def mass_properties() -> dict[str, MassProps]:
    """Mass properties of every moving link (not the chassis)."""
    props = {name: _members_props(ms) for name, ms in MEMBERS.items()}
    props.update(_cylinder_props("lift"))
    props.update(_cylinder_props("tilt"))
    return props


# ----------------------------------------------------------------------- planar poses
def _rot(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s], [s, c]])


def _p(name) -> np.ndarray:
    return np.array(POINTS[name], dtype=float)


@dataclass(frozen=True)
class PlanarPose:
    """Arm pose (rotation ``arm_angle`` about, and translation of, its reference
    BKPT), bucket rotation relative to the arm, and the cylinder lengths (m, rad)."""

    arm_angle: float
    pin: np.ndarray          # BKPT (x, z)
    bucket_angle: float      # bucket rotation relative to the arm, rad (CCW +)
    lift_length: float
    tilt_length: float

    def point(self, name: str) -> np.ndarray:
        """World (x, z) of a named point of the arm, bucket or chassis."""
        ref = _p("BKPT")
        if name in LINK_POINTS["bucket"]:
            return self.pin + _rot(self.arm_angle + self.bucket_angle) @ (_p(name) - ref)
        if name in LINK_POINTS["lift_arm"]:
            return self.pin + _rot(self.arm_angle) @ (_p(name) - ref)
        if name in LINK_POINTS["chassis"]:
            return _p(name)
        raise KeyError(f"point {name!r} is not on the chassis, arm or bucket")


_L_LOWER = float(np.linalg.norm(_p("LLAPT") - _p("LCPT")))
_L_UPPER = float(np.linalg.norm(_p("ULAPT") - _p("UCPT")))


def _arm_residual(x, lift_length):
    pin, a = x[:2], x[2]
    ref = _p("BKPT")

    def arm(n):
        return pin + _rot(a) @ (_p(n) - ref)

    return [np.linalg.norm(arm("LLAPT") - _p("LCPT")) - _L_LOWER,
            np.linalg.norm(arm("ULAPT") - _p("UCPT")) - _L_UPPER,
            np.linalg.norm(arm("ULCPT") - _p("LLCPT")) - lift_length]


def solve_arm(lift_length: float, guess=None) -> tuple[np.ndarray, float]:
    """BKPT position (2,) and arm angle (rad) for a lift length, by scipy ``fsolve``
    on the upper-control and lower-lifting loops, from ``guess`` (pin x, z, angle)."""
    x0 = np.array([*POINTS["BKPT"], 0.0]) if guess is None else np.asarray(guess, float)
    # judged by the residual: at xtol=1e-14 fsolve may report "no further improvement"
    x, _, _, msg = fsolve(_arm_residual, x0, args=(lift_length,), xtol=1e-14, full_output=True)
    if np.abs(_arm_residual(x, lift_length)).max() > 1e-11:
        raise RuntimeError(f"loader arm loops do not close at lift length {lift_length}: {msg}")
    return x[:2], float(x[2])


def solve_bucket(pin, arm_angle, tilt_length, guess=0.0) -> float:
    """Bucket angle relative to the arm closing the bucket loop for a tilt length."""
    ref = _p("BKPT")
    ut = pin + _rot(arm_angle) @ (_p("UTCPT") - ref)

    def res(b):
        lt = pin + _rot(arm_angle + b[0]) @ (_p("LTCPT") - ref)
        return [np.linalg.norm(lt - ut) - tilt_length]

    b, _, _, msg = fsolve(res, [guess], xtol=1e-14, full_output=True)
    if abs(res(b)[0]) > 1e-11:
        raise RuntimeError(f"loader bucket loop does not close at tilt length {tilt_length}: {msg}")
    return float(b[0])


def pose(lift_length: float, tilt_length: float, guess: PlanarPose | None = None) -> PlanarPose:
    """Assembled planar pose for both cylinder lengths (continuation from ``guess``)."""
    g = None if guess is None else [*guess.pin, guess.arm_angle]
    pin, a = solve_arm(lift_length, g)
    b = solve_bucket(pin, a, tilt_length, 0.0 if guess is None else guess.bucket_angle)
    return PlanarPose(a, pin, b, lift_length, tilt_length)


def level_tilt_length(pin, arm_angle, bucket_pitch: float = 0.0) -> float:
    """Tilt length that holds the bucket at ``bucket_pitch`` (rad, CCW +) to the ground."""
    ref = _p("BKPT")
    ut = pin + _rot(arm_angle) @ (_p("UTCPT") - ref)
    lt = pin + _rot(bucket_pitch) @ (_p("LTCPT") - ref)
    return float(np.linalg.norm(lt - ut))


def lift_sweep(n: int = 61, bucket_pitch: float = 0.0) -> list[PlanarPose]:
    """Poses over the full lift stroke, tilt length chosen to hold the bucket level."""
    cyl = CYLINDERS["lift"]
    poses, prev = [], None
    for L in np.linspace(cyl.min_length, cyl.max_length, n):
        g = None if prev is None else [*prev.pin, prev.arm_angle]
        pin, a = solve_arm(L, g)
        T = level_tilt_length(pin, a, bucket_pitch)
        prev = PlanarPose(a, pin, bucket_pitch - a, L, T)
        poses.append(prev)
    return poses


def com_xz(p: PlanarPose, link: str, props: dict[str, MassProps]) -> np.ndarray:
    """World (x, z) of a moving link's centre of mass in pose ``p``."""
    c = props[link].com[[0, 2]]
    ref = _p("BKPT")
    if link == "lift_arm":
        return p.pin + _rot(p.arm_angle) @ (c - ref)
    if link == "bucket":
        return p.pin + _rot(p.arm_angle + p.bucket_angle) @ (c - ref)
    pivots = {"lower_link": ("LCPT", "LLAPT"), "upper_link": ("UCPT", "ULAPT"),
              "lift_barrel": ("LLCPT", "ULCPT"), "lift_rod": ("ULCPT", "LLCPT"),
              "tilt_barrel": ("UTCPT", "LTCPT"), "tilt_rod": ("LTCPT", "UTCPT")}
    a, b = pivots[link]  # the part turns with the line a -> b and keeps its offset from a
    pa, pb = p.point(a), p.point(b)
    ang = np.arctan2(*(pb - pa)[::-1]) - np.arctan2(*(_p(b) - _p(a))[::-1])
    return pa + _rot(ang) @ (c - _p(a))


def draw(path) -> None:
    """Side-view sketch at the lower, middle and upper lift positions (bucket level)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sweep = lift_sweep(61)
    fig, ax = plt.subplots(figsize=(8, 7))
    ax.plot(*np.array([p.pin for p in sweep]).T, ":", color="gray", label="hinge-pin path")
    chassis = np.array([(-0.75, 0.25), (-0.75, 1.60), (-0.40, 1.68), (0.35, 1.90),
                        (0.95, 1.90), (1.10, 0.90), (1.25, 0.25), (-0.75, 0.25)])
    ax.fill(*chassis.T, color="0.92", ec="0.6", label="chassis (outline, estimate)")
    for axle in ("REAR_AXLE", "FRONT_AXLE"):
        ax.add_patch(plt.Circle(POINTS[axle], 0.35, fill=False, color="0.5"))
    for p, col, lab in ((sweep[0], "C0", "lower"), (sweep[30], "C1", "middle"),
                        (sweep[-1], "C2", "upper")):
        def line(names, **kw):
            ax.plot(*np.array([p.point(n) for n in names]).T, color=col, **kw)
        line(("LLAPT", "ULAPT", "ARM_BEND", "BKPT"), lw=3, label=f"{lab}")
        line(("ARM_BEND", "UTCPT"), lw=2)
        line(("ARM_BEND", "ULCPT", "BKPT"), lw=1)  # lug plate of the lift-cylinder pin
        line(("LCPT", "LLAPT"), lw=2)
        line(("UCPT", "ULAPT"), lw=2)
        line(("LLCPT", "ULCPT"), lw=5, alpha=0.5)
        line(("UTCPT", "LTCPT"), lw=5, alpha=0.5)
        line(("BKPT", "BUCKET_TOP_BACK", "BUCKET_HEEL", "BUCKET_EDGE", "BUCKET_LIP",
              "BUCKET_TOP_BACK"), lw=1.5)
        ax.annotate("", p.point("LOAD") + [0, -0.25], p.point("LOAD"),
                    arrowprops=dict(arrowstyle="->", color=col))
    p = sweep[0]
    for n in ("UCPT", "LCPT", "LLCPT", "ULAPT", "LLAPT", "ULCPT", "UTCPT", "BKPT", "LTCPT"):
        x, z = p.point(n)
        ax.plot(x, z, "ko", ms=3)
        ax.annotate(n, (x, z), textcoords="offset points", xytext=(4, -9), fontsize=7)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m), forward")
    ax.set_ylabel("z (m), up")
    ax.set_title("Skid-steer loader linkage (L555 class, estimated): lower, middle, upper")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    from pathlib import Path

    draw(Path(__file__).resolve().parents[2] / "docs" / "front_loader_geometry.png")
