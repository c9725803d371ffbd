"""Front-end loader geometry: loops close over the stroke, a plausible bucket path,
and cylinder forces for the rated load from planar virtual work (scipy loop
solutions) cross-checked by free-body statics."""

from __future__ import annotations

import loader_geometry as lg
import numpy as np
import pytest

W = lg.RATED_LOAD_N
H = 1e-6  # m: central-difference step on cylinder lengths


def _z_load(L, T, guess):
    return lg.pose(L, T, guess).point("LOAD")[1]


def vw_forces(p: lg.PlanarPose) -> tuple[float, float]:
    """Cylinder forces (N, + = push/compression) from virtual work with the load only:
    F_c dL_c = W dz_load  =>  F_c = W dz_load/dL_c (other cylinder held)."""
    L, T = p.lift_length, p.tilt_length
    f_lift = W * (_z_load(L + H, T, p) - _z_load(L - H, T, p)) / (2 * H)
    f_tilt = W * (_z_load(L, T + H, p) - _z_load(L, T - H, p)) / (2 * H)
    return f_lift, f_tilt


def _unit(v):
    return v / np.linalg.norm(v)


def _cross(r, f):
    return r[0] * f[1] - r[1] * f[0]  # z-moment in the (x, z) plane seen from -y


def statics_forces(p: lg.PlanarPose) -> tuple[float, float]:
    """Independent free-body statics (no differentiation): tilt force from the bucket's
    moment about BKPT; lift force from the equilibrium of arm + bucket + tilt cylinder
    under the two-force lower/upper links, the lift cylinder and the load."""
    load = np.array([0.0, -W])
    bk, rl = p.point("BKPT"), p.point("LOAD")
    lt, ut = p.point("LTCPT"), p.point("UTCPT")
    u_t = _unit(lt - ut)  # push of the tilt cylinder on the bucket
    f_tilt = -_cross(rl - bk, load) / _cross(lt - bk, u_t)
    cols, pts = [], []
    for base, tip in (("LCPT", "LLAPT"), ("UCPT", "ULAPT"), ("LLCPT", "ULCPT")):
        a, b = p.point(base), p.point(tip)
        u = _unit(b - a)
        cols.append([u[0], u[1], _cross(b - bk, u)])
    A = np.array(cols).T  # unknown push forces of lower link, upper link, lift cylinder
    rhs = -np.array([load[0], load[1], _cross(rl - bk, load)])
    return float(np.linalg.solve(A, rhs)[2]), float(f_tilt)


@pytest.fixture(scope="module")
def sweep():
    return lg.lift_sweep(61)


def test_reference_configuration_is_assembled():
    p = lg.pose(lg.REFERENCE_LIFT_LENGTH, lg.REFERENCE_TILT_LENGTH)
    assert abs(p.arm_angle) < 1e-12 and abs(p.bucket_angle) < 1e-12
    np.testing.assert_allclose(p.pin, lg.POINTS["BKPT"], atol=1e-12)


def test_loops_close_over_the_full_lift_stroke(sweep):
    cyl = lg.CYLINDERS
    for p in sweep:
        # every loop re-measured from the assembled points
        lens = {
            "lower": (p.point("LLAPT"), p.point("LCPT")),
            "upper": (p.point("ULAPT"), p.point("UCPT")),
        }
        for (a, b), ref in zip(lens.values(), ("LLAPT-LCPT", "ULAPT-UCPT")):
            p0, p1 = (np.array(lg.POINTS[n]) for n in ref.split("-"))
            assert abs(np.linalg.norm(a - b) - np.linalg.norm(p0 - p1)) < 1e-11
        assert abs(np.linalg.norm(p.point("ULCPT") - p.point("LLCPT")) - p.lift_length) < 1e-11
        assert abs(np.linalg.norm(p.point("LTCPT") - p.point("UTCPT")) - p.tilt_length) < 1e-11
        assert abs(p.arm_angle + p.bucket_angle) < 1e-12  # bucket held level
        assert cyl["tilt"].min_length <= p.tilt_length <= cyl["tilt"].max_length
    # fixed tilt length also sweeps (bucket rolls back with the arm)
    prev = None
    for L in np.linspace(cyl["lift"].min_length, cyl["lift"].max_length, 31):
        prev = lg.pose(L, lg.REFERENCE_TILT_LENGTH, prev)
        assert abs(prev.bucket_angle) < 1e-9


def test_arm_motion_is_continuous_with_good_transmission_angles(sweep):
    ang = np.array([p.arm_angle for p in sweep])
    assert np.all(np.diff(ang) > 0) and np.diff(ang).max() < np.radians(2.0)
    mus = []
    for p in sweep:
        coupler = p.point("ULAPT") - p.point("LLAPT")
        for base, tip in (("LCPT", "LLAPT"), ("UCPT", "ULAPT")):
            link = p.point(tip) - p.point(base)
            c = abs(link @ coupler) / np.linalg.norm(link) / np.linalg.norm(coupler)
            mus.append(np.degrees(np.arccos(c)))
    print(f"\nfour-bar transmission angle: min {min(mus):.1f} deg")
    assert min(mus) > 40.0


def test_bucket_pin_path_is_plausible(sweep):
    pins = np.array([p.pin for p in sweep])
    print(f"\nhinge pin: z {pins[0, 1]:.3f} -> {pins[-1, 1]:.3f} m, "
          f"x {pins[:, 0].min():.3f}..{pins[:, 0].max():.3f} m, arm rotation "
          f"{np.degrees(sweep[-1].arm_angle):.1f} deg")
    assert 0.15 < pins[0, 1] < 0.30           # pin just above the ground, bucket down
    assert 2.70 < pins[-1, 1] < 2.90          # ~2.8 m hinge-pin height at full lift
    assert np.all(np.diff(pins[:, 1]) > 0)    # rises monotonically
    assert 1.2 < pins[:, 0].min() and pins[:, 0].max() < 2.0  # radial: reach peaks mid-way
    assert np.argmax(pins[:, 0]) not in (0, len(pins) - 1)
    # rollback at the ground and a 40 deg dump at full height within the tilt stroke
    t = lg.CYLINDERS["tilt"]
    lo, hi = sweep[0], sweep[-1]
    assert t.min_length <= lg.level_tilt_length(lo.pin, lo.arm_angle, np.radians(25))
    assert lg.level_tilt_length(hi.pin, hi.arm_angle, np.radians(-40)) <= t.max_length


def test_virtual_work_forces_equal_free_body_statics(sweep):
    for p in sweep[::6]:
        vw, st = vw_forces(p), statics_forces(p)
        np.testing.assert_allclose(vw, st, rtol=1e-6)


def test_cylinder_forces_are_of_the_seed_order(sweep):
    lift, tilt = np.array([vw_forces(p) for p in sweep]).T
    strokes = np.array([p.lift_length for p in sweep]) - sweep[0].lift_length
    print("\nlift stroke (cm) | lift force (kN, push) | tilt force (kN, + push) [load only]")
    for k in range(0, len(sweep), 10):
        print(f"  {100 * strokes[k]:5.1f} | {lift[k] / 1e3:6.2f} | {tilt[k] / 1e3:6.2f}")
    # seed Fig. 3.45: 12-14 kN lift; Fig. 3.44: ~10.4 kN tilt (sign not given)
    assert 10e3 < lift.min() and lift.max() < 20e3
    assert np.all(np.abs(tilt) > 5e3) and np.all(np.abs(tilt) < 15e3)
    # tilt sweep at the ground (seed Fig. 3.44: tilt position 0 .. -60 mm)
    p0 = sweep[0]
    f = []
    for dT in np.linspace(0.0, -0.060, 7):
        p = lg.pose(p0.lift_length, p0.tilt_length + dT, p0)
        f.append(vw_forces(p)[1])
    print("tilt cylinder 0..-60 mm at the ground, tilt force (kN):",
          " ".join(f"{x / 1e3:.2f}" for x in f))
    assert np.all(np.abs(f) > 7e3) and np.all(np.abs(f) < 16e3)


def test_mass_properties_are_plausible_steel_parts():
    mp = lg.mass_properties()
    assert set(mp) == set(lg.LINK_POINTS) - {"chassis"}
    for name, m in mp.items():
        evals = np.linalg.eigvalsh(m.inertia)
        assert m.mass > 0 and np.all(evals > 0), name
        assert evals[2] <= evals[0] + evals[1] + 1e-9, name  # triangle inequality
        assert abs(m.com[1]) < 1e-12, name  # symmetric about the machine centre plane
    assert 120 < mp["lift_arm"].mass < 250 and 120 < mp["bucket"].mass < 250
    # slender-rod check of the formula: a link's Iyy ~ m L^2/12 about its centre
    low = mp["lower_link"]
    L = np.hypot(*np.subtract(lg.POINTS["LLAPT"], lg.POINTS["LCPT"]))
    assert low.inertia[1, 1] == pytest.approx(low.mass * L**2 / 12, rel=1e-12)


def test_topology_tables_are_consistent():
    names = {j.name for j in lg.JOINTS}
    links = set(lg.LINK_POINTS) | {"ground"}
    for j in lg.JOINTS:
        assert j.parent in links and j.child in links and j.point in lg.POINTS
        assert j.type in ("revolute", "prismatic")
    for loop in lg.LOOPS:
        assert set(loop.joints) <= names
    # planar mobility relative to the chassis: 3 (bodies) - 2 (joints) = the two cylinders
    moving = len(lg.LINK_POINTS) - 1
    joints = [j for j in lg.JOINTS if j.parent != "ground"]
    assert 3 * moving - 2 * len(joints) == 2
    # three independent loops = joints - bodies (spanning tree has one joint per body)
    assert len(joints) - moving == len(lg.LOOPS) == 3


def test_cylinder_forces_with_link_weights(sweep):
    """Same virtual work with the potential energy of every moving link added
    (V = W z_load + sum m g z_com): weights add to the lift force."""
    mp = lg.mass_properties()

    def V(L, T, guess):
        p = lg.pose(L, T, guess)
        return W * p.point("LOAD")[1] + sum(lg.G * m.mass * lg.com_xz(p, k, mp)[1]
                                            for k, m in mp.items())

    rows = []
    for p in sweep[::10]:
        L, T = p.lift_length, p.tilt_length
        f_lift = (V(L + H, T, p) - V(L - H, T, p)) / (2 * H)
        f_tilt = (V(L, T + H, p) - V(L, T - H, p)) / (2 * H)
        rows.append((L - sweep[0].lift_length, f_lift, f_tilt, vw_forces(p)[0]))
    print("\nwith link weights: stroke (cm) | lift (kN) | tilt (kN)")
    for s, fl, ft, _ in rows:
        print(f"  {100 * s:5.1f} | {fl / 1e3:6.2f} | {ft / 1e3:6.2f}")
    for _, fl, _, fl_load in rows:
        assert fl_load < fl < 40e3
