"""The numpy reference of the link poses and the loop closure: the oracle of
:mod:`pipeline.kinematics.compiled`.

The forward recursion over the mechanism's steps on 4x4 matrices (local matrices of every
step, then [A, dA] and [A | A' | A''] link by link) and the closure rows of every loop, as
:mod:`pipeline.kinematics.poses` describes them, in numpy. The package evaluates them once,
compiled; these are kept here, outside it, to test it against.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pipeline.kinematics.mechanism import Mechanism, Step

_I4 = np.eye(4)
_I = ([2, 0, 1], [1, 2, 0])  # vee(E) = (E[I] - E[I^T]) / 2
_IT = ([1, 2, 0], [2, 0, 1])
_Z4 = np.zeros((4, 4))
_NO_D = np.zeros((0, 4, 4))
for _a in (_Z4, _NO_D):
    _a.setflags(write=False)


def _fast_local(fast, q, qd, need_d):
    """Closed-form M, dM, M', M'' of a rigid one-motion step (see ``Step.fast``)."""
    kind, C0, C1, C2, i = fast
    if kind == "fixed":
        return C0, _NO_D, (None if qd is None else _Z4), (None if qd is None else _Z4)
    x = q[i]
    if kind == "T":
        M, dM0, Mdd = C0 + x * C1, C1, _Z4
    else:
        c, s = math.cos(x), math.sin(x)
        M = C0 + s * C1 + (1.0 - c) * C2
        dM0 = c * C1 + s * C2
        Mdd = None if qd is None else (qd[i] * qd[i]) * (c * C2 - s * C1)
    return M, (dM0[None] if need_d else None), (None if qd is None else qd[i] * dM0), Mdd


def step_local(step: Step, q: np.ndarray, qd: np.ndarray | None = None, need_d: bool = True):
    """Local matrix M (4, 4), dM/dq_local (k, 4, 4), M' and M''|q''=0 of a step."""
    if step.fast is not None:
        return _fast_local(step.fast, q, qd, need_d)
    fr = step.frame
    eta = q[step.eta_idx] if fr.n_modes else None
    S = fr.shape(eta) if fr.n_modes else fr.pose
    dS = fr.shape_derivatives(eta) if fr.n_modes else None
    tail = step.tail
    if step.motion is not None:
        G, dG, Gd, Gdd = step.motion.evaluate(q[step.q_idx], None if qd is None else qd[step.q_idx])
    else:
        G, dG, Gd, Gdd = _I4, None, _Z4, _Z4
    SG = S @ G
    M = SG if tail is None else SG @ tail
    dM = Md = Mdd = None
    if need_d:
        parts = []
        if fr.n_modes:
            parts.append(dS @ G)
        if dG is not None:
            parts.append(S @ dG)
        dM = np.concatenate(parts) if len(parts) > 1 else parts[0] if parts else np.zeros((0, 4, 4))
        if tail is not None:
            dM = dM @ tail
    if qd is not None:
        if fr.n_modes:
            Sd = (qd[step.eta_idx] @ dS.reshape(fr.n_modes, 16)).reshape(4, 4)
            Md = Sd @ G + S @ Gd
            Mdd = 2.0 * Sd @ Gd + S @ Gdd
            Sdd = fr.shape_acceleration(qd[step.eta_idx])
            if Sdd is not None:  # a second-order frame: S'' = eta'^T H eta'
                Mdd = Mdd + Sdd @ G
        else:
            Md, Mdd = S @ Gd, S @ Gdd
        if tail is not None:
            Md, Mdd = Md @ tail, Mdd @ tail
    return M, dM, Md, Mdd


def step_value(step: Step, A, dA, Ad, Add, q, qd=None, need_d=True) -> tuple:
    """P, dP, Pd, Pdd of a step's end from the state of its base link (all (L, ...)
    arrays): the oracle of :func:`pipeline.kinematics.poses.step_value`."""
    f = step.frm
    M, dM, Md, Mdd = step_local(step, q, qd, need_d)
    Af = A[f]
    P = Af @ M
    dP = None
    if need_d:
        dP = dA[f] @ M
        if step.fast is not None and step.fast[4] >= 0:  # one local coordinate
            dP[step.fast[4]] += Af @ dM[0]
        elif len(step.local):
            dP[step.local] += Af @ dM
    Pd = Pdd = None
    if qd is not None:
        Pd = Ad[f] @ M + Af @ Md
        Pdd = Add[f] @ M + 2.0 * Ad[f] @ Md + Af @ Mdd
    return P, dP, Pd, Pdd


@dataclass(frozen=True)
class NumpyTree:
    """A, dA, Ad, Add as :class:`pipeline.kinematics.poses.TreeState`, with the stacked
    Z (L, 1 + n, 4, 4) = [A, dA] and Y (L, 4, 12) = [A | A' | A''] the recursion builds."""

    A: np.ndarray
    dA: np.ndarray | None
    Ad: np.ndarray | None
    Add: np.ndarray | None
    Z: np.ndarray | None = None
    Y: np.ndarray | None = None


@dataclass(frozen=True)
class NumpyClosure:
    """r (6 k,), J (6 k, n) or None, gamma (6 k,) or None, the tree and the local matrices."""

    r: np.ndarray
    J: np.ndarray | None
    gamma: np.ndarray | None
    tree: NumpyTree
    local: object = None


@dataclass(frozen=True)
class _Stacks:
    """The constant matrices of the rigid one-motion steps stacked for vectorised
    evaluation: step indices iR, iT, iF, iG of rotation, translation, fixed and general
    steps; R0, R1, R2 (nR, 4, 4) and coordinates qR of the rotations; T0, T1 and qT of the
    translations; F0 of the fixed steps (Step.fast)."""

    iR: np.ndarray
    iT: np.ndarray
    iF: np.ndarray
    iG: np.ndarray
    R0: np.ndarray
    R1: np.ndarray
    R2: np.ndarray
    qR: np.ndarray
    T0: np.ndarray
    T1: np.ndarray
    qT: np.ndarray
    F0: np.ndarray


def _stacks(mech: Mechanism) -> _Stacks:
    steps = mech.table.steps
    kind = [st.fast[0] if st.fast is not None else "G" for st in steps]
    idx = {k: np.array([i for i, x in enumerate(kind) if x == k], dtype=int)
           for k in ("R", "T", "fixed", "G")}

    def stack(k, j):
        return np.array([steps[i].fast[j] for i in idx[k]]).reshape(-1, 4, 4)

    def coord(k):
        return np.array([steps[i].fast[4] for i in idx[k]], dtype=int)

    return _Stacks(idx["R"], idx["T"], idx["fixed"], idx["G"], stack("R", 1), stack("R", 2),
                   stack("R", 3), coord("R"), stack("T", 1), stack("T", 2), coord("T"),
                   stack("fixed", 1))


@dataclass(frozen=True)
class Locals:
    """Local matrices of every step of ``mech.table`` at one configuration.

    M, D1 : (S, 4, 4) M and dM/dx of one-motion steps (0 otherwise);
    general : {step index: dM (k, 4, 4)} of the other steps;
    MB : (S, 12, 12) block matrix [[M, M', M''], [0, M, 2 M'], [0, 0, M]] with
        M'' at q'' = 0 (None without rates), so that [A | A' | A''] MB gives
        [A M | (A M)' | (A M)''] in one product.
    """

    M: np.ndarray
    D1: np.ndarray
    general: dict
    MB: np.ndarray | None


def local_matrices(mech: Mechanism, q: np.ndarray, qd: np.ndarray | None = None,
                   need_d: bool = True) -> Locals:
    """Evaluate every step's local matrix at once (rigid one-motion steps vectorised);
    with rates qd (n,) also M', M'' (see :func:`local_rates`)."""
    tab = _stacks(mech)
    S = len(mech.table.steps)
    M, D1 = np.empty((S, 4, 4)), np.zeros((S, 4, 4))
    if tab.iR.size:
        x = q[tab.qR][:, None, None]
        c, s = np.cos(x), np.sin(x)
        M[tab.iR] = tab.R0 + s * tab.R1 + (1.0 - c) * tab.R2
        D1[tab.iR] = c * tab.R1 + s * tab.R2
    if tab.iT.size:
        M[tab.iT] = tab.T0 + q[tab.qT][:, None, None] * tab.T1
        D1[tab.iT] = tab.T1
    if tab.iF.size:
        M[tab.iF] = tab.F0
    general = {}
    for k in tab.iG:
        M[k], general[k], _, _ = step_local(mech.table.steps[k], q, None, need_d)
    loc = Locals(M, D1, general, None)
    return loc if qd is None else local_rates(mech, q, qd, loc)


def local_rates(mech: Mechanism, q: np.ndarray, qd: np.ndarray, loc: Locals) -> Locals:
    """``loc`` (evaluated at q without rates) completed with the rate block MB at qd (n,).

    Lets a caller close the loops first and add the rates once q' is known,
    without evaluating the positions twice.
    """
    tab = _stacks(mech)
    M = loc.M
    Md, Mdd = np.zeros_like(M), np.zeros_like(M)
    if tab.iR.size:
        x = q[tab.qR][:, None, None]
        c, s = np.cos(x), np.sin(x)
        w = qd[tab.qR][:, None, None]
        Md[tab.iR] = w * loc.D1[tab.iR]
        Mdd[tab.iR] = (w * w) * (c * tab.R2 - s * tab.R1)
    if tab.iT.size:
        Md[tab.iT] = qd[tab.qT][:, None, None] * tab.T1
    for k in tab.iG:
        _, _, Md[k], Mdd[k] = step_local(mech.table.steps[k], q, qd, need_d=False)
    MB = np.zeros((M.shape[0], 12, 12))
    for b in range(3):
        MB[:, 4 * b:4 * b + 4, 4 * b:4 * b + 4] = M
    MB[:, 0:4, 4:8] = Md
    MB[:, 4:8, 8:12] = 2.0 * Md
    MB[:, 0:4, 8:12] = Mdd
    return Locals(M, loc.D1, loc.general, MB)


def place_d(k: int, loc: Locals, mech: Mechanism, Z: np.ndarray) -> np.ndarray:
    """(1 + n, 4, 4) [P, dP/dq] of step k from the stacked [A, dA/dq] (L, 1 + n, 4, 4)."""
    st = mech.table.steps[k]
    Zf = Z[st.frm]
    out = Zf @ loc.M[k]
    if st.fast is not None:
        if st.fast[4] >= 0:
            out[1 + st.fast[4]] += Zf[0] @ loc.D1[k]
    elif len(st.local):
        out[1 + st.local] += Zf[0] @ loc.general[k]
    return out


def place_rates(k: int, loc: Locals, mech: Mechanism, Y: np.ndarray) -> np.ndarray:
    """(4, 12) [P | P' | P''(q''=0)] of step k from [A | A' | A''] (L, 4, 12)."""
    return Y[mech.table.steps[k].frm] @ loc.MB[k]


def evaluate_tree(mech: Mechanism, q: np.ndarray, qd: np.ndarray | None = None,
                  derivatives: bool = True, loc: Locals | None = None) -> NumpyTree:
    """Poses of every link at q (n,); with ``derivatives`` also dA/dq; with qd also A', A''.

    Parameters
    ----------
    q : (n,) coordinates (rad, m, modal).
    qd : (n,) coordinate rates, optional.
    derivatives : compute dA/dq (L, n, 4, 4).
    loc : local matrices already evaluated at (q, qd) (see :func:`local_matrices`).
    compiled : without ``loc``, use the compiled pass (:mod:`pipeline.kinematics.compiled`);
        False runs this module's numpy reference implementation.
    """
    L, n = len(mech.links), mech.n
    if loc is None:
        loc = local_matrices(mech, q, qd, derivatives)
    order, slots = mech.placement, mech.table.tree_slot
    A = dA = Ad = Add = Z = Y = None
    if derivatives:
        Z = np.zeros((L, 1 + n, 4, 4))
        Z[order[0], 0] = _I4
        for li in order[1:]:
            Z[li] = place_d(slots[li], loc, mech, Z)
        A, dA = Z[:, 0], Z[:, 1:]
    if qd is not None:
        Y = _tree_rates(mech, loc)
        A, Ad, Add = Y[:, :, :4], Y[:, :, 4:8], Y[:, :, 8:]
    if A is None:
        A = np.empty((L, 4, 4))
        A[order[0]] = _I4
        for li in order[1:]:
            k = slots[li]
            A[li] = A[mech.table.steps[k].frm] @ loc.M[k]
    return NumpyTree(A, dA, Ad, Add, Z, Y)


def _tree_rates(mech: Mechanism, loc: Locals) -> np.ndarray:
    """(L, 4, 12) [A | A' | A''(q''=0)] of every link from local matrices with rates."""
    order, slots = mech.placement, mech.table.tree_slot
    Y = np.zeros((len(mech.links), 4, 12))
    Y[order[0], :, :4] = _I4
    for li in order[1:]:
        Y[li] = place_rates(slots[li], loc, mech, Y)
    return Y


def tree_with_rates(mech: Mechanism, tree, loc: Locals) -> NumpyTree:
    """``tree`` (with dA, no rates) completed with A', A'' from ``loc`` (:func:`local_rates`)."""
    Y = _tree_rates(mech, loc)
    return NumpyTree(tree.A, tree.dA, Y[:, :, 4:8], Y[:, :, 8:], tree.Z, Y)


def closure(mech: Mechanism, q: np.ndarray, qd: np.ndarray | None = None,
            jacobian: bool = True) -> NumpyClosure:
    """Residual, Jacobian (if ``jacobian``) and gamma (if ``qd``) at q (n,)."""
    q = np.asarray(q, dtype=float)
    loc = local_matrices(mech, q, qd, jacobian)
    tree = evaluate_tree(mech, q, qd, jacobian, loc)
    K, n = len(mech.loop_steps), mech.n
    if K == 0:
        return NumpyClosure(np.zeros(0), np.zeros((0, n)) if jacobian else None,
                            None if qd is None else np.zeros(0), tree, loc)
    slots = [k for pair in mech.table.loop_slot for k in pair]
    J = g = None
    if jacobian:
        Zs = np.array([place_d(k, loc, mech, tree.Z) for k in slots]).reshape(K, 2, 1 + n, 4, 4)
        P, dP = Zs[:, :, 0], Zs[:, :, 1:]
    else:
        P = np.array([tree.A[mech.table.steps[k].frm] @ loc.M[k] for k in slots]).reshape(
            K, 2, 4, 4)
    RL, RR = P[:, 0, :3, :3], P[:, 1, :3, :3]
    RLt = RL.transpose(0, 2, 1)
    r = np.empty((K, 6))
    r[:, :3] = P[:, 0, :3, 3] - P[:, 1, :3, 3]
    r[:, 3:] = _vee(RR @ RLt)
    if jacobian:
        J = np.empty((K, 6, n))
        J[:, :3] = (dP[:, 0, :, :3, 3] - dP[:, 1, :, :3, 3]).transpose(0, 2, 1)
        dE = dP[:, 1, :, :3, :3] @ RLt[:, None] + RR[:, None] @ dP[:, 0, :, :3, :3].transpose(
            0, 1, 3, 2)
        J[:, 3:] = _vee(dE).transpose(0, 2, 1)
        J = J.reshape(6 * K, n)
    if qd is not None:
        g = _gamma(mech, loc, tree)
    return NumpyClosure(r.reshape(-1), J, g, tree, loc)


def _gamma(mech: Mechanism, loc: Locals, tree) -> np.ndarray:
    """(6 k,) gamma from local matrices and a tree with rates."""
    K = len(mech.loop_steps)
    slots = [k for pair in mech.table.loop_slot for k in pair]
    Ys = np.array([place_rates(k, loc, mech, tree.Y) for k in slots]).reshape(K, 2, 4, 12)
    P, Pd, Pdd = Ys[..., :4], Ys[..., 4:8], Ys[..., 8:]
    RLt = P[:, 0, :3, :3].transpose(0, 2, 1)
    g = np.empty((K, 6))
    g[:, :3] = Pdd[:, 1, :3, 3] - Pdd[:, 0, :3, 3]
    E2 = Pdd[:, 1, :3, :3] @ RLt + 2.0 * Pd[:, 1, :3, :3] @ Pd[:, 0, :3, :3].transpose(
        0, 2, 1) + P[:, 1, :3, :3] @ Pdd[:, 0, :3, :3].transpose(0, 2, 1)
    g[:, 3:] = -_vee(E2)
    return g.reshape(-1)


def closure_rates(mech: Mechanism, c: NumpyClosure, q: np.ndarray,
                  qd: np.ndarray) -> NumpyClosure:
    """``c`` (evaluated at q with the Jacobian, no rates) completed with gamma and the tree's
    A', A'' at the rates qd (n,), without evaluating the positions again."""
    loc = local_rates(mech, q, np.asarray(qd, dtype=float), c.local)
    tree = tree_with_rates(mech, c.tree, loc)
    g = _gamma(mech, loc, tree) if mech.loop_steps else np.zeros(0)
    return NumpyClosure(c.r, c.J, g, tree, loc)


def _vee(E: np.ndarray) -> np.ndarray:
    """(..., 3) axial vector of the skew part of E (..., 3, 3)."""
    return 0.5 * (E[..., _I[0], _I[1]] - E[..., _IT[0], _IT[1]])
