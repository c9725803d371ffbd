"""Tree poses, closure Jacobian and gamma vs central finite differences on a
random spatial mechanism with every joint type, flexible links (frames of first and of
second order in the modal coordinates), joints crossed child-to-parent and three
loops."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.kinematics import (
    Joint,
    build_mechanism,
    closure,
    closure_residual,
    evaluate_tree,
    flexible_link,
    rigid_link,
)
from pipeline.kinematics.closure import closure_rates
from pipeline.kinematics.poses import step_value
from pipeline.kinematics.rotations import exp_so3, homogeneous

H = 1e-6


def _pose(rng):
    return homogeneous(exp_so3(rng.normal(size=3)), rng.normal(size=3))


def _flex(rng, m, name, frames, second=False):
    """Random frames; ``second``: with second-order translations (Frame.hess) too."""
    return flexible_link(name, {f: (_pose(rng), 0.3 * rng.normal(size=(m, 3)),
                                    0.3 * rng.normal(size=(m, 3)),
                                    0.3 * rng.normal(size=(m, m, 3)) if second else None)
                                for f in frames})


@pytest.fixture(scope="module", params=[False, True], ids=["first-order", "second-order"])
def mech(request):
    rng = np.random.default_rng(11)
    second = request.param
    links = [
        rigid_link("ground", {f: _pose(rng) for f in ("g1", "g2", "g3")}),
        rigid_link("L1", {"a": _pose(rng), "c": _pose(rng)}),
        _flex(rng, 2, "L2", ("f1", "f2"), second),
        rigid_link("L3", {"a": _pose(rng), "b": _pose(rng)}),
        _flex(rng, 3, "L4", ("f1", "f2"), second),
        rigid_link("L5", {"a": _pose(rng)}),
    ]
    joints = [
        Joint("j1", "free", "ground", "g1", "L1", "body"),
        Joint("j2", "universal", "L1", "a", "L2", "body"),
        Joint("j3", "spherical", "L2", "f1", "L3", "a"),
        Joint("j4", "planar", "L3", "body", "ground", "g2"),
        Joint("j5", "cylindrical", "ground", "g3", "L4", "body"),
        Joint("j6", "revolute", "L4", "f1", "L3", "b"),
        Joint("j7", "prismatic", "L2", "f2", "L4", "f2"),
        Joint("j8", "fixed", "L5", "a", "L1", "c"),
    ]
    return build_mechanism(links, joints)


def _rel(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


def _state(mech, seed):
    rng = np.random.default_rng(seed)
    return rng.uniform(-1, 1, mech.n), rng.normal(size=mech.n)


def test_topology_of_the_test_mechanism(mech):
    topo = mech.topology
    assert len(topo.loops) == 3 == len(mech.joints) - (len(mech.links) - 1)
    assert any(not e.forward for e in topo.edges)  # some joint crossed child -> parent
    # both of j7's frames deform with modes, so it can only be a cut joint
    assert "j7" in [mech.joints[k].name for k in topo.cut_joints]
    assert len(mech.modal_coordinates) == 5


@pytest.mark.parametrize("seed", [1, 2])
def test_link_pose_derivatives_equal_fd(mech, seed):
    q, qd = _state(mech, seed)
    st = evaluate_tree(mech, q, qd)
    for i in range(mech.n):
        e = np.zeros(mech.n)
        e[i] = H
        fd = (evaluate_tree(mech, q + e, derivatives=False).A
              - evaluate_tree(mech, q - e, derivatives=False).A) / (2 * H)
        assert np.abs(st.dA[:, i] - fd).max() <= 1e-7 * max(1.0, np.abs(fd).max())
    assert np.allclose(st.Ad, np.einsum("lnij,n->lij", st.dA, qd), atol=1e-13)
    fd2 = (evaluate_tree(mech, q + H * qd, qd).Ad - evaluate_tree(mech, q - H * qd, qd).Ad) / (2 * H)
    assert _rel(st.Add, fd2) < 1e-7


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_closure_jacobian_equals_fd(mech, seed):
    q, _ = _state(mech, seed)
    c = closure(mech, q)
    assert np.allclose(c.r, closure_residual(mech, q), atol=1e-14)
    fd = np.column_stack([(closure_residual(mech, q + H * e) - closure_residual(mech, q - H * e))
                          / (2 * H) for e in np.eye(mech.n)])
    assert _rel(c.J, fd) < 1e-7
    assert np.all(np.abs(c.J - fd) <= 1e-7 * np.abs(c.J).max())


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_gamma_equals_fd_of_jacobian_times_rates(mech, seed):
    q, qd = _state(mech, seed)
    g = closure(mech, q, qd).gamma
    fd = -(closure(mech, q + H * qd).J @ qd - closure(mech, q - H * qd).J @ qd) / (2 * H)
    assert _rel(g, fd) < 1e-7


def test_marker_pose_derivatives_equal_fd(mech):
    q, qd = _state(mech, 4)
    st = mech.marker("L4", "f2")
    tree = evaluate_tree(mech, q, qd)
    v = step_value(st, tree.A, tree.dA, tree.Ad, tree.Add, q, qd)

    def pose(x):
        t = evaluate_tree(mech, x, derivatives=False)
        return step_value(st, t.A, None, None, None, x, None, False).P

    for i in range(mech.n):
        e = np.zeros(mech.n)
        e[i] = H
        fd = (pose(q + e) - pose(q - e)) / (2 * H)
        assert np.abs(v.dP[i] - fd).max() <= 1e-7 * max(1.0, np.abs(fd).max())
    assert np.allclose(v.Pd, np.einsum("nij,n->ij", v.dP, qd), atol=1e-13)


@pytest.mark.parametrize("seed", [3, 4, 5])
def test_compiled_pass_equals_the_numpy_reference(mech, seed):
    """The compiled pass (pipeline.kinematics.compiled), the package's one evaluation of the
    poses and closure rows, against the numpy oracle (tests/kinematics/poses_numpy.py):
    every joint type, flexible frames on both sides of the loops."""
    import poses_numpy as numpy_ref

    q, qd = _state(mech, seed)
    fast, ref = closure(mech, q, qd), numpy_ref.closure(mech, q, qd)
    for a, b in ((fast.r, ref.r), (fast.J, ref.J), (fast.gamma, ref.gamma),
                 (fast.tree.A, ref.tree.A), (fast.tree.dA, ref.tree.dA),
                 (fast.tree.Ad, ref.tree.Ad), (fast.tree.Add, ref.tree.Add)):
        assert a.shape == b.shape and _rel(a, b) < 1e-13
    st = evaluate_tree(mech, q, None, derivatives=False)
    assert st.dA is None and st.Ad is None
    assert _rel(st.A, numpy_ref.evaluate_tree(mech, q, derivatives=False).A) < 1e-14
    # the positions-only pass agrees with the full one
    assert _rel(closure(mech, q).J, ref.J) < 1e-13
    # rates added to a positions-only evaluation (numpy: from its local matrices) equal
    # the full evaluation with rates
    for c0, rates in ((numpy_ref.closure(mech, q), numpy_ref.closure_rates),
                      (closure(mech, q), closure_rates)):
        added = rates(mech, c0, q, qd)
        for a, b in ((added.gamma, ref.gamma), (added.tree.Ad, ref.tree.Ad),
                     (added.tree.Add, ref.tree.Add), (added.J, ref.J)):
            assert _rel(a, b) < 1e-13


@pytest.mark.parametrize("links", [(), ("L5",), ("L3", "L5")])
def test_derivatives_for_some_links_keep_theirs_and_their_ancestors_whole(mech, links):
    """``derivatives_for`` (what the equations of motion use: dA at the force elements'
    markers and the loops' ends): those links', the loops' ends' and their ancestors' dA
    equal the complete evaluation's, every other link keeps the columns of its own step's coordinates (the
    inertia terms read those) and the rest of its dA is zero; poses, rates and closure
    rows are unchanged."""
    from pipeline.kinematics.compiled import _kernel

    q, qd = _state(mech, 5)
    cm = mech.compiled
    full = _kernel(q, qd, True, *cm.arrays())
    part = _kernel(q, qd, True, *cm.derivatives_for([mech.link_index(n) for n in links])
                   .arrays())
    for k in (0, 2, 3, 4, 5, 6):
        assert np.array_equal(full[k], part[k])
    table = mech.table
    whole = set()
    ends = [table.steps[s].frm for pair in table.loop_slot for s in pair]
    # the named links, the loops' ends and their ancestors, by the tree's own table
    for li in [mech.link_index(name) for name in links] + ends:
        while li != cm.root:
            whole.add(li)
            li = table.steps[table.tree_slot[li]].frm
    for li in range(len(mech.links)):
        if li == cm.root:
            continue
        if li in whole:
            assert np.array_equal(part[1][li], full[1][li])
        else:
            own = list(table.steps[table.tree_slot[li]].local)
            assert np.array_equal(part[1][li, own], full[1][li, own])
            rest = np.setdiff1d(np.arange(mech.n), own)
            assert not part[1][li, rest].any()
            assert full[1][li, rest].any() or not cm.depends[li, rest].any()


@pytest.mark.parametrize("seed", [6, 7])
def test_compiled_step_values_equal_the_numpy_reference(mech, seed):
    """Markers, force points and joint frames are evaluated by the tree's own compiled step
    code (step_value); against the numpy oracle on every step of the table (every joint
    type, the closed forms of one-motion steps, flexible frames of both orders) and on a
    marker of every frame: pose, dP/dq, P' and P'' at q'' = 0, and the pose alone."""
    import poses_numpy as numpy_ref

    q, qd = _state(mech, seed)
    tree = evaluate_tree(mech, q, qd)
    steps = list(mech.table.steps) + [mech.marker(lk.name, f.name) for lk in mech.links
                                      for f in lk.frames]
    assert any(st.fast is not None for st in steps) and any(st.fast is None for st in steps)
    for st in steps:
        v = step_value(st, tree.A, tree.dA, tree.Ad, tree.Add, q, qd)
        ref = numpy_ref.step_value(st, tree.A, tree.dA, tree.Ad, tree.Add, q, qd)
        for a, b in zip((v.P, v.dP, v.Pd, v.Pdd), ref, strict=True):
            assert a.shape == b.shape and np.abs(a - b).max() <= 1e-13 * max(1, np.abs(b).max())
        pose = step_value(st, tree.A, None, None, None, q, None, need_d=False)
        assert pose.dP is None and pose.Pd is None
        assert np.abs(pose.P - ref[0]).max() <= 1e-14 * max(1, np.abs(ref[0]).max())
