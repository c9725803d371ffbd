"""Interfaces: selection, validation and the RBE2 transformation."""

from dataclasses import dataclass

import numpy as np
import pytest
from conftest import box_model

from pipeline.core.errors import ConfigError
from pipeline.fem.interfaces import (
    InterfaceSpec,
    interface_operator,
    make_interface,
    resolve_interfaces,
    tie_interfaces,
)


@dataclass(frozen=True)
class XPlane:
    """Minimal selector for the tests: candidate nodes with x == value."""

    x: float

    def select(self, points, candidates, groups):
        c = np.asarray(candidates)
        return np.sort(c[np.isclose(points[c, 0], self.x)])


@dataclass(frozen=True)
class Group:
    name: str

    def select(self, points, candidates, groups):
        if self.name not in groups:
            raise ConfigError(f"unknown group {self.name!r}; available: {sorted(groups)}")
        return np.intersect1d(groups[self.name], candidates)


def _ends(model):
    return [InterfaceSpec("root", XPlane(0.0), [0, 0.01, 0.005]),
            ("tip", XPlane(0.4), [0.4, 0.01, 0.005], None, "rbe3")]


def test_resolve_selects_boundary_nodes_of_each_face(bar):
    root, tip = resolve_interfaces(bar, _ends(bar))
    assert root.kind == "rbe2" and tip.kind == "rbe3"
    # 16x2x2 structured P2 mesh: end face has (2*2+1)^2 = 25 nodes
    assert root.nodes.size == 25 and tip.nodes.size == 25
    assert np.allclose(bar.nodes[root.nodes, 0], 0.0) and np.allclose(bar.nodes[tip.nodes, 0], 0.4)
    np.testing.assert_array_equal(root.axes, np.eye(3))


def test_resolve_with_groups_and_mapping_spec(bar):
    groups = {"end": np.flatnonzero(np.isclose(bar.nodes[:, 0], 0.4))}
    (itf,) = resolve_interfaces(bar, [{"name": "g", "selector": Group("end"),
                                       "origin": [0.4, 0, 0], "kind": "rbe3"}], groups)
    np.testing.assert_array_equal(itf.nodes, np.sort(groups["end"]))


def test_selector_matching_nothing_names_link_and_interface(bar):
    with pytest.raises(ConfigError, match=r"link 'bar': interface 'pin': selector XPlane\(x=9.0\) "
                                          r"matched no nodes"):
        resolve_interfaces(bar, [("pin", XPlane(9.0), [0, 0, 0])])


def test_selector_error_is_wrapped_with_names(bar):
    with pytest.raises(ConfigError, match=r"link 'bar': interface 'g': .*unknown group 'nope'"):
        resolve_interfaces(bar, [("g", Group("nope"), [0, 0, 0])], {"a": np.arange(3)})


@pytest.mark.parametrize("spec, message", [
    ((("a", XPlane(0.0), [0, 0, 0]), ("a", XPlane(0.4), [0, 0, 0])), "duplicate interface name"),
    ((("a", XPlane(0.0), [0, 0, 0], None, "rbe9"),),
     r"kind: expected one of \('rbe2', 'rbe3'\), got 'rbe9'"),
    ((("a", XPlane(0.0), [0, 0]),), r"origin: expected shape \(3,\)"),
    ((("a", XPlane(0.0), [0, 0, 0], 2 * np.eye(3)),), "axes: expected a proper rotation"),
])
def test_bad_specs_raise_clear_errors(bar, spec, message):
    with pytest.raises(ConfigError, match=r"link 'bar': interface 'a': .*" + message):
        resolve_interfaces(bar, spec)


def test_collinear_nodes_cannot_carry_six_dofs(bar):
    line = np.flatnonzero(np.isclose(bar.nodes[:, 1], 0) & np.isclose(bar.nodes[:, 2], 0))
    with pytest.raises(ConfigError, match="at least 3 non-collinear nodes"):
        make_interface(bar, "edge", [0, 0, 0], None, "rbe2", line)


def test_overlapping_rbe2_interfaces_are_rejected(bar):
    a = make_interface(bar, "a", [0, 0, 0], None, "rbe2", np.arange(10))
    b = make_interface(bar, "b", [0, 0, 0], None, "rbe2", np.arange(5, 20))
    with pytest.raises(ConfigError, match="share nodes"):
        tie_interfaces(bar, [a, b])


def test_rbe2_transformation_moves_nodes_rigidly(bar):
    root, tip = resolve_interfaces(bar, _ends(bar)[:1] + [("tip", XPlane(0.4), [0.45, 0.0, 0.0])])
    tied = tie_interfaces(bar, [root, tip])
    assert tied.n_red == bar.n_dof - 3 * 25 * 2 + 12
    rng = np.random.default_rng(1)
    u_r = rng.standard_normal(tied.n_red)
    u = (tied.transform @ u_r)
    for itf in (root, tip):
        t, th = np.split(u_r[tied.master_dofs[itf.name]], 2)
        expected = t + np.cross(th, bar.nodes[itf.nodes] - itf.origin)
        np.testing.assert_allclose(u[bar.node_dofs[itf.nodes]], expected, rtol=0, atol=1e-14)
    # independent DOFs pass through unchanged, in order
    free = np.setdiff1d(np.arange(bar.n_dof), bar.node_dofs[np.r_[root.nodes, tip.nodes]].ravel())
    np.testing.assert_array_equal(u[free], u_r[:free.size])


def test_tied_matrices_are_projections_and_rigid_motions_stay_free():
    model = box_model(nx=4, ny=1, nz=1)
    root, tip = resolve_interfaces(model, [("root", XPlane(0.0), [0, 0.01, 0.005]),
                                           ("tip", XPlane(0.4), [0.5, 0.0, 0.02])])
    tied = tie_interfaces(model, [root, tip])
    T = tied.transform.toarray()
    K_r = T.T @ model.stiffness.toarray() @ T
    assert np.abs(tied.stiffness.toarray() - K_r).max() <= 1e-12 * np.abs(K_r).max()
    # a rigid motion of the whole bar, written in tied coordinates by hand:
    # free DOFs first (in order), then [t + theta x origin, theta] per master
    th, t = np.array([0.1, -0.2, 0.3]), np.array([1.0, 2.0, 3.0])
    u_full = np.zeros(model.n_dof)
    u_full[model.node_dofs.reshape(-1)] = (t + np.cross(th, model.nodes)).reshape(-1)
    slaves = model.node_dofs[np.r_[root.nodes, tip.nodes]].ravel()
    masters = [np.r_[t + np.cross(th, i.origin), th] for i in (root, tip)]
    u_r = np.concatenate([np.delete(u_full, slaves), *masters])
    np.testing.assert_allclose(T @ u_r, u_full, rtol=0, atol=1e-14)
    assert abs(u_r @ tied.stiffness @ u_r) <= 1e-9 * np.abs(K_r).max()


def test_rbe3_operator_reads_rigid_motion_exactly(bar):
    _, tip = resolve_interfaces(bar, _ends(bar))
    G = interface_operator(bar, tip)
    th, t = np.array([0.01, -0.02, 0.03]), np.array([1e-3, 2e-3, -1e-3])
    u_full = np.zeros(bar.n_dof)
    u_full[bar.node_dofs.reshape(-1)] = (t + np.cross(th, bar.nodes - tip.origin)).reshape(-1)
    np.testing.assert_allclose(G @ u_full, np.r_[t, th], rtol=1e-12, atol=1e-15)


def test_rbe3_adds_no_stiffness(bar):
    _, tip = resolve_interfaces(bar, _ends(bar))
    tied = tie_interfaces(bar, [tip])
    assert tied.n_red == bar.n_dof and tied.master_dofs == {}
    assert tied.stiffness is not None and (tied.stiffness != bar.stiffness).nnz == 0
    assert (tied.mass != bar.mass).nnz == 0
    assert "tip" in tied.rbe3_operators


def test_beam_interface_must_be_one_node():
    model = box_model(nx=2, ny=1, nz=1)
    beam_like = type(model)("b", "beam", model.nodes[:4], np.arange(24).reshape(4, 6),
                            model.stiffness[:24, :24], model.mass[:24, :24])
    with pytest.raises(ConfigError, match="a beam interface is exactly one node, got 2"):
        make_interface(beam_like, "end", [0, 0, 0], None, "rbe2", [0, 1])


def test_a_selector_that_finds_nothing_says_where_the_mesh_is(bar):
    """A model drawn in one unit and read in another selects nothing; the error shows the
    mesh's bounding box so the slip is visible."""
    lo, hi = bar.nodes.min(axis=0), bar.nodes.max(axis=0)
    with pytest.raises(ConfigError, match=rf"matched no nodes; the mesh spans x "
                                          rf"\[{lo[0]:.4g}, {hi[0]:.4g}\], y"):
        resolve_interfaces(bar, [("pin", XPlane(400.0), [400.0, 0, 0])])
