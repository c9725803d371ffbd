"""Compiled evaluation of the link poses and the loop closure (numba): the one evaluation
of the whole tree and its loops (:func:`pipeline.kinematics.poses.evaluate_tree` and
:func:`pipeline.kinematics.closure.closure` call it; their numpy form is the tests' oracle,
``tests/kinematics/poses_numpy.py``), one machine-code pass over flat arrays. Why: a
reduced state of a closed-loop machine needs the poses, their derivatives in every
coordinate, their rates and the closure rows several times per time step; in numpy those
are hundreds of calls on 4x4 arrays whose per-call overhead dominates (front-end loader,
15 coordinates: ~1 ms per pass in numpy, ~20 us compiled).

Every step is written in one general form,

    M = S(eta) F_1(x_1) ... F_k(x_k) tail,   S(eta) = pose + sum_a eta_a dS_a,

with F_i = exp(x_i G_i) an elementary rotation (I + sin x G + (1 - cos x) G^2)
or translation (I + x G) and G_i the signed generator, so dF_i/dx_i = F_i G_i;
M' and M''|q''=0 follow by the product rule (S is linear in eta, S'' = 0).

Examples
--------
>>> import numpy as np
>>> from pipeline.kinematics import Joint, build_mechanism, rigid_link
>>> from pipeline.kinematics.rotations import translation
>>> m = build_mechanism([rigid_link("ground"), rigid_link("arm", {"tip": translation([1, 0, 0])})],
...                     [Joint("pin", "revolute", "ground", "body", "arm", "body")])
>>> ev = evaluate(m.compiled, np.array([np.pi / 2]), np.array([1.0]))
>>> np.round(ev.A[1, :3, 0], 12).tolist(), np.round(ev.Ad[1, :3, 0], 12).tolist()
([0.0, 1.0, 0.0], [-1.0, 0.0, 0.0])
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from pipeline.core import kernel_cache  # noqa: F401  (numba's cache kept consistent)

__all__ = ["CompiledMechanism", "CompiledSteps", "Evaluation", "StepValues", "compile_mechanism",
           "compile_steps", "evaluate", "step_values"]


@dataclass(frozen=True)
class CompiledSteps:
    """Flat arrays of S steps (at most MM modes and KK motions each): the form the tree,
    the loops, a marker, a force element's point or a joint's frame are evaluated in.

    frm (S,) base link; n_modes (S,), eta (S, MM) modal coordinates, pose (S, 4, 4),
    dS (S, MM, 4, 4) shape derivatives; n_motions (S,), kind (S, KK) 0 rotation /
    1 translation, gen (S, KK, 4, 4) signed generators, gen2 their squares, qi (S, KK)
    coordinate of each factor; tail (S, 4, 4); fast (S,) the closed form of a rigid step
    with at most one motion (-1 none, 0 rotation, 1 translation, 2 fixed; Step.fast), with
    its constant matrices fastC (S, 3, 4, 4) = C0, C1, C2 and coordinate fastq (S,);
    second (S,) whether the step's frame has second-order translation, hess (S, MM, MM,
    3) its d2r/deta_a deta_b (Frame.hess; a (1, 1, 1, 3) dummy when no frame has one).
    """

    frm: np.ndarray
    n_modes: np.ndarray
    eta: np.ndarray
    pose: np.ndarray
    dS: np.ndarray
    n_motions: np.ndarray
    kind: np.ndarray
    gen: np.ndarray
    gen2: np.ndarray
    qi: np.ndarray
    tail: np.ndarray
    fast: np.ndarray
    fastC: np.ndarray
    fastq: np.ndarray
    second: np.ndarray
    hess: np.ndarray

    def arrays(self) -> tuple:
        """The arrays in the order of :func:`_values_kernel`'s arguments."""
        return (self.frm, self.n_modes, self.eta, self.pose, self.dS, self.n_motions,
                self.kind, self.gen, self.gen2, self.qi, self.tail, self.fast, self.fastC,
                self.fastq, self.second, self.hess)


@dataclass(frozen=True)
class CompiledMechanism:
    """Flat arrays of a mechanism: its ``steps`` (:class:`CompiledSteps`, every step of
    ``Mechanism.table``), order (L - 1,) links in placement order after the root, slot
    (L,) their step; loops (K, 2) steps of each loop's two sides; depends (L, n) whether
    a link's pose depends on a coordinate (dA is zero elsewhere: the derivative products
    are skipped there); loop_depends (K, n) the same for the closure rows of each loop;
    derive (L,) whether a link's dA is complete (all True; :meth:`derivatives_for`).
    """

    n: int
    n_links: int
    root: int
    steps: CompiledSteps
    order: np.ndarray
    slot: np.ndarray
    loops: np.ndarray
    depends: np.ndarray
    loop_depends: np.ndarray
    derive: np.ndarray

    def arrays(self) -> tuple:
        """The arrays in the order of the kernels' arguments (after q, qd, rates)."""
        s = self.steps
        return (self.n_links, self.root, s.frm, s.n_modes, s.eta, s.pose, s.dS, s.n_motions,
                s.kind, s.gen, s.gen2, s.qi, s.tail, self.order, self.slot, self.loops,
                self.depends, self.loop_depends, self.derive, s.fast, s.fastC, s.fastq,
                s.second, s.hess)

    def derivatives_for(self, links) -> CompiledMechanism:
        """This mechanism evaluated with dA complete only for ``links`` (indices), the
        links the loops close on (the closure Jacobian reads them) and their ancestors;
        every other link's dA holds only the columns of its own joint's and frame's
        coordinates (what the inertia terms read), zero elsewhere. Why: a link's complete
        dA costs a 4x4 product per coordinate above it, O(N^2) for a chain of N links,
        where the equations of motion need it only at the force elements' markers and
        the loops' ends."""
        derive = np.zeros(self.n_links, dtype=np.bool_)
        frm = self.steps.frm
        for li in np.concatenate([np.asarray(links, dtype=np.int64).ravel(),
                                  frm[self.loops.ravel()]]):
            li = int(li)
            while li != self.root and not derive[li]:
                derive[li] = True
                li = int(frm[self.slot[li]])
        return replace(self, derive=derive)


@dataclass(frozen=True)
class Evaluation:
    """Poses and closure at one state: A (L, 4, 4), dA (L, n, 4, 4), Ad, Add (L, 4, 4) or
    None without rates; r (6 K,), J (6 K, n), gamma (6 K,) or None without rates."""

    A: np.ndarray
    dA: np.ndarray
    Ad: np.ndarray | None
    Add: np.ndarray | None
    r: np.ndarray
    J: np.ndarray
    gamma: np.ndarray | None


def compile_steps(steps) -> CompiledSteps:
    """Flatten a sequence of :class:`pipeline.kinematics.mechanism.Step`."""
    S = len(steps)
    MM = max([1] + [st.frame.n_modes for st in steps])
    KK = max([1] + [st.motion.n if st.motion is not None else 0 for st in steps])
    frm = np.array([st.frm for st in steps], dtype=np.int64).reshape(S)
    n_modes = np.zeros(S, dtype=np.int64)
    eta = np.zeros((S, MM), dtype=np.int64)
    pose = np.zeros((S, 4, 4))
    dS = np.zeros((S, MM, 4, 4))
    n_motions = np.zeros(S, dtype=np.int64)
    kind = np.zeros((S, KK), dtype=np.int64)
    gen = np.zeros((S, KK, 4, 4))
    qi = np.zeros((S, KK), dtype=np.int64)
    tail = np.tile(np.eye(4), (S, 1, 1))
    second = np.array([st.frame.hess is not None for st in steps], dtype=np.bool_).reshape(S)
    hess = np.zeros((S, MM, MM, 3) if second.any() else (1, 1, 1, 3))
    fast = np.full(S, -1, dtype=np.int64)
    fastC = np.zeros((S, 3, 4, 4))
    fastq = np.zeros(S, dtype=np.int64)
    codes = {"R": 0, "T": 1, "fixed": 2}
    for s, st in enumerate(steps):
        m = st.frame.n_modes
        n_modes[s] = m
        eta[s, :m] = st.eta_idx
        pose[s] = st.frame.pose
        dS[s, :m] = st.frame.dshape
        if second[s]:
            hess[s, :m, :m] = st.frame.hess
        if st.motion is not None:
            k = st.motion.n
            n_motions[s] = k
            kind[s, :k] = [0 if c == "R" else 1 for c in st.motion.kinds]
            gen[s, :k] = st.motion.generators
            qi[s, :k] = [st.q_idx[v] for v in st.motion.var]
        if st.tail is not None:
            tail[s] = st.tail
        if st.fast is not None:
            fast[s] = codes[st.fast[0]]
            for k in range(3):
                if st.fast[1 + k] is not None:
                    fastC[s, k] = st.fast[1 + k]
            fastq[s] = max(st.fast[4], 0)
    return CompiledSteps(frm, n_modes, eta, pose, dS, n_motions, kind, gen, gen @ gen, qi,
                         tail, fast, fastC, fastq, second, hess)


def compile_mechanism(mech) -> CompiledMechanism:
    """Flatten ``mech.table`` (a :class:`pipeline.kinematics.mechanism.Mechanism`)."""
    steps = mech.table.steps
    cs = compile_steps(steps)
    order = np.array(mech.placement[1:], dtype=np.int64)
    slot = np.array(mech.table.tree_slot, dtype=np.int64)
    loops = np.array(mech.table.loop_slot, dtype=np.int64).reshape(-1, 2)
    depends = np.zeros((len(mech.links), mech.n), dtype=np.bool_)
    for li in order:
        st = steps[slot[li]]
        depends[li] = depends[st.frm]
        depends[li, st.local] = True
    loop_depends = np.zeros((loops.shape[0], mech.n), dtype=np.bool_)
    for kk, pair in enumerate(loops):
        for s in pair:
            loop_depends[kk] |= depends[steps[s].frm]
            loop_depends[kk, steps[s].local] = True
    return CompiledMechanism(mech.n, len(mech.links), int(mech.placement[0]), cs, order,
                             slot, loops, depends, loop_depends,
                             np.ones(len(mech.links), dtype=np.bool_))


@dataclass(frozen=True)
class StepValues:
    """Global poses P = A_frm M of some steps' ends and their derivatives: P (S, 4, 4);
    dP (S, n, 4, 4) dP/dq, or None; Pd, Pdd (S, 4, 4) P' and P''|q''=0, or None."""

    P: np.ndarray
    dP: np.ndarray | None
    Pd: np.ndarray | None
    Pdd: np.ndarray | None


def step_values(cs: CompiledSteps, q: np.ndarray, A: np.ndarray, dA: np.ndarray | None = None,
                Ad: np.ndarray | None = None, Add: np.ndarray | None = None,
                qd: np.ndarray | None = None) -> StepValues:
    """Poses of the ends of the steps ``cs`` from the link poses A (L, 4, 4) at q (n,):
    with dA (L, n, 4, 4) also dP/dq; with qd (n,), Ad and Add (L, 4, 4) also P', P''."""
    q = np.ascontiguousarray(q, dtype=float)
    n, L = q.shape[0], A.shape[0]
    need_d = dA is not None
    rates = qd is not None
    none = np.zeros((L, 4, 4))
    P, dP, Pd, Pdd = _values_kernel(
        q, np.ascontiguousarray(qd, dtype=float) if rates else np.zeros(n), rates, need_d,
        np.ascontiguousarray(A, dtype=float),
        # a pose alone: no coordinate to differentiate by (_place's dA loop is empty)
        np.ascontiguousarray(dA, dtype=float) if need_d else np.zeros((L, 0, 4, 4)),
        np.ascontiguousarray(Ad, dtype=float) if rates else none,
        np.ascontiguousarray(Add, dtype=float) if rates else none, *cs.arrays())
    return StepValues(P, dP if need_d else None, Pd if rates else None,
                      Pdd if rates else None)


def evaluate(cm: CompiledMechanism, q: np.ndarray, qd: np.ndarray | None = None) -> Evaluation:
    """Poses, their q-derivatives, closure residual and Jacobian at q (n,); with qd (n,)
    also the pose rates A', A''|q''=0 and gamma."""
    q = coordinate_vector(q, cm.n, "q")
    rates = qd is not None
    qd = coordinate_vector(qd, cm.n, "qd") if rates else np.zeros_like(q)
    A, dA, Ad, Add, r, J, g = _kernel(q, qd, rates, *cm.arrays())
    if not rates:
        return Evaluation(A, dA, None, None, r, J, None)
    return Evaluation(A, dA, Ad, Add, r, J, g)


def coordinate_vector(x, n: int, name: str = "q") -> np.ndarray:
    """x as a contiguous float (n,) array; a ValueError for any other length.

    The kernels index their state by the mechanism's tables without bounds checks, so a
    vector of another model (a case that keeps fewer modes) would be read and written
    past its end; this check at their entry makes that mistake loud.

    >>> coordinate_vector([0, 1], 3)
    Traceback (most recent call last):
    ...
    ValueError: q has 2 entries; the mechanism has 3 coordinates
    """
    x = np.ascontiguousarray(x, dtype=float)
    if x.shape != (n,):
        raise ValueError(f"{name} has {x.size if x.ndim == 1 else x.shape} entries; "
                         f"the mechanism has {n} coordinates")
    return x


# --------------------------------------------------------------------------- kernels
@njit(cache=True, inline='always')
def _mm(X, Y, out):
    """out = X @ Y for 4x4 (out must not alias X or Y)."""
    for i in range(4):
        for j in range(4):
            out[i, j] = X[i, 0] * Y[0, j] + X[i, 1] * Y[1, j] + X[i, 2] * Y[2, j] \
                + X[i, 3] * Y[3, j]


@njit(cache=True, inline='always')
def _mm_add(X, Y, c, out):
    """out += c X @ Y for 4x4."""
    for i in range(4):
        for j in range(4):
            out[i, j] += c * (X[i, 0] * Y[0, j] + X[i, 1] * Y[1, j] + X[i, 2] * Y[2, j]
                              + X[i, 3] * Y[3, j])


@njit(cache=True)
def _step(s, q, qd, rates, n_modes, eta, pose, dS, n_motions, kind, gen, gen2, qi, tail,
          second, hess, M, dMe, dMx, Md, Mdd, F, P, T, Sm, Sd, U, V, X, Xd, Xdd, Fd, Fdd, W,
          Sdd, hv):
    """Local matrix of step s and its derivatives (see the module docstring); F, P, T
    ((KK + 1, 4, 4)), the 4x4 arrays after them and hv (MM, 3) are work space."""
    m, k = n_modes[s], n_motions[s]
    Sm[:] = pose[s]
    Sd[:] = 0.0
    for a in range(m):
        e = q[eta[s, a]]
        ed = qd[eta[s, a]]
        for i in range(4):
            for j in range(4):
                Sm[i, j] += e * dS[s, a, i, j]
                Sd[i, j] += ed * dS[s, a, i, j]
    if second[s]:  # origin column: + eta^T H eta / 2; dS_a + H_ab eta_b; S'' = eta'^T H eta'
        Sdd[:] = 0.0
        for a in range(m):
            for i in range(3):
                hv[a, i] = 0.0
            for b in range(m):
                e = q[eta[s, b]]
                for i in range(3):
                    hv[a, i] += hess[s, a, b, i] * e
        for a in range(m):
            e = q[eta[s, a]]
            ed = qd[eta[s, a]]
            for i in range(3):
                Sm[i, 3] += 0.5 * e * hv[a, i]
                Sd[i, 3] += ed * hv[a, i]
                for b in range(m):
                    Sdd[i, 3] += ed * qd[eta[s, b]] * hess[s, a, b, i]
    for i in range(k):
        x = q[qi[s, i]]
        if kind[s, i] == 0:
            c1, c2 = np.sin(x), 1.0 - np.cos(x)
        else:
            c1, c2 = x, 0.0
        for r in range(4):
            for c in range(4):
                F[i, r, c] = c1 * gen[s, i, r, c] + c2 * gen2[s, i, r, c]
            F[i, r, r] += 1.0
    # prefix P[i] = F_0 .. F_i-1, suffix T[i] = F_i .. F_k-1 tail
    P[0] = 0.0
    for r in range(4):
        P[0, r, r] = 1.0
    for i in range(k):
        _mm(P[i], F[i], P[i + 1])
    T[k] = tail[s]
    for i in range(k - 1, -1, -1):
        _mm(F[i], T[i + 1], T[i])
    _mm(Sm, T[0], M)
    for a in range(m):
        _mm(dS[s, a], T[0], dMe[a])
        if second[s]:
            for i in range(3):
                for c in range(4):
                    dMe[a, i, c] += hv[a, i] * T[0, 3, c]
    for i in range(k):
        _mm(P[i + 1], gen[s, i], U)
        _mm(U, T[i + 1], V)
        _mm(Sm, V, dMx[i])
    if not rates:
        return
    X[:] = P[0]  # identity
    Xd[:] = 0.0
    Xdd[:] = 0.0
    for i in range(k):
        w = qd[qi[s, i]]
        _mm(F[i], gen[s, i], Fd)
        _mm(F[i], gen2[s, i], Fdd)
        for r in range(4):
            for c in range(4):
                Fd[r, c] *= w
                Fdd[r, c] *= w * w
        # X'' <- X'' F + 2 X' F' + X F'';  X' <- X' F + X F';  X <- X F
        W[:] = 0.0
        _mm_add(Xdd, F[i], 1.0, W)
        _mm_add(Xd, Fd, 2.0, W)
        _mm_add(X, Fdd, 1.0, W)
        Xdd[:] = W
        W[:] = 0.0
        _mm_add(Xd, F[i], 1.0, W)
        _mm_add(X, Fd, 1.0, W)
        Xd[:] = W
        _mm(X, F[i], W)
        X[:] = W
    # M' = (S' G + S G') tail,  M'' = (2 S' G' + S G'') tail
    W[:] = 0.0
    _mm_add(Sd, X, 1.0, W)
    _mm_add(Sm, Xd, 1.0, W)
    _mm(W, tail[s], Md)
    W[:] = 0.0
    _mm_add(Sd, Xd, 2.0, W)
    _mm_add(Sm, Xdd, 1.0, W)
    if second[s]:
        _mm_add(Sdd, X, 1.0, W)
    _mm(W, tail[s], Mdd)


@njit(cache=True, inline='always')
def _mmi(X, i, Y, j, c, out, k):
    """out[k] += c X[i] @ Y[j] on 4x4 blocks of (., 4, 4) arrays, indexed rather than
    sliced: each slice of an array takes and drops an atomic reference count, which in
    these loops cost as much as the products (half a rigid four-bar's evaluation)."""
    for r in range(4):
        x0, x1, x2, x3 = X[i, r, 0], X[i, r, 1], X[i, r, 2], X[i, r, 3]
        for col in range(4):
            out[k, r, col] += c * (x0 * Y[j, 0, col] + x1 * Y[j, 1, col]
                                   + x2 * Y[j, 2, col] + x3 * Y[j, 3, col])


@njit(cache=True, inline='always')
def _zero(X, k):
    for r in range(4):
        for col in range(4):
            X[k, r, col] = 0.0


@njit(cache=True)
def _place(f, s, A, dA, nd, n_modes, eta, n_motions, qi, Ms, dMe, MM, dMx, KK, P, dP, n, o,
           depends, inherit):
    """Global pose P[o] = A_f M_s of step s's end and its derivatives dP[o n + i] = dP/dq_i;
    the link poses A (L, 4, 4) and dA (L nd, 4, 4) (link l's derivative by q_i in row
    l nd + i); the steps' local matrices Ms (S, 4, 4), dMe (S MM, 4, 4), dMx (S KK, 4, 4).
    Without ``inherit`` only the derivatives in the step's own coordinates (those rows of
    dP must be zero). The rates are :func:`_place_rates`'s: an array used only in a
    branch keeps the reference count the call took on it (an atomic operation each)."""
    _zero(P, o)
    _mmi(A, f, Ms, s, 1.0, P, o)
    base = o * n
    for i in range(nd if inherit else 0):
        _zero(dP, base + i)
        if depends[f, i]:
            _mmi(dA, f * nd + i, Ms, s, 1.0, dP, base + i)
    for a in range(n_modes[s]):
        _mmi(A, f, dMe, s * MM + a, 1.0, dP, base + eta[s, a])
    for i in range(n_motions[s]):
        _mmi(A, f, dMx, s * KK + i, 1.0, dP, base + qi[s, i])


@njit(cache=True)
def _place_rates(f, s, A, Ad, Add, Ms, Md, Mdd, Pd, Pdd, o):
    """The rates Pd[o], Pdd[o] of step s's end placed on link f (:func:`_place`), from the
    link's A, Ad, Add (L, 4, 4) and the step's Ms, Md, Mdd (S, 4, 4)."""
    _zero(Pd, o)
    _mmi(Ad, f, Ms, s, 1.0, Pd, o)
    _mmi(A, f, Md, s, 1.0, Pd, o)
    _zero(Pdd, o)
    _mmi(Add, f, Ms, s, 1.0, Pdd, o)
    _mmi(Ad, f, Md, s, 2.0, Pdd, o)
    _mmi(A, f, Mdd, s, 1.0, Pdd, o)


@njit(cache=True, inline='always')
def _abt_add(X, i, Y, j, c, out):
    """out += c X[i][:3, :3] @ Y[j][:3, :3]^T (rotation blocks of (., 4, 4) arrays,
    indexed: see :func:`_mmi`)."""
    for r in range(3):
        for k in range(3):
            out[r, k] += c * (X[i, r, 0] * Y[j, k, 0] + X[i, r, 1] * Y[j, k, 1]
                              + X[i, r, 2] * Y[j, k, 2])


@njit(cache=True, inline='always')
def _vee_into(E, out, o, sign):
    """out[o:o+3] = sign * axial vector of the skew part of the 3x3 block of E."""
    out[o] = sign * 0.5 * (E[2, 1] - E[1, 2])
    out[o + 1] = sign * 0.5 * (E[0, 2] - E[2, 0])
    out[o + 2] = sign * 0.5 * (E[1, 0] - E[0, 1])


@njit(cache=True)
def _fast_steps(q, qd, rates, fast, fastC, fastq, M, dM, Md, Mdd):
    """The rigid steps with at most one motion (Step.fast; the others have fast[s] < 0), in
    closed form: rotation M = C0 + sin x C1 + (1 - cos x) C2, translation M = C0 + x C1,
    fixed M = C0, into M[s], dM[s, 0], Md[s], Mdd[s]. All of them in one call, indexed
    rather than sliced: a call (inlined or not) takes a reference count on each array it
    is given, which per step cost more than the step's arithmetic (see :func:`_mmi`)."""
    for s in range(fast.shape[0]):
        k = fast[s]
        if k == 2:  # fixed: no coordinate to read (a mechanism may have none: q is empty)
            for i in range(4):
                for j in range(4):
                    M[s, i, j] = fastC[s, 0, i, j]
        elif k == 0:
            x, w = q[fastq[s]], qd[fastq[s]]
            sn, cs = np.sin(x), np.cos(x)
            for i in range(4):
                for j in range(4):
                    c1, c2 = fastC[s, 1, i, j], fastC[s, 2, i, j]
                    M[s, i, j] = fastC[s, 0, i, j] + sn * c1 + (1.0 - cs) * c2
                    d = cs * c1 + sn * c2
                    dM[s, 0, i, j] = d
                    if rates:
                        Md[s, i, j] = w * d
                        Mdd[s, i, j] = w * w * (cs * c2 - sn * c1)
        elif k == 1:
            x, w = q[fastq[s]], qd[fastq[s]]
            for i in range(4):
                for j in range(4):
                    c1 = fastC[s, 1, i, j]
                    M[s, i, j] = fastC[s, 0, i, j] + x * c1
                    dM[s, 0, i, j] = c1
                    if rates:
                        Md[s, i, j] = w * c1
                        Mdd[s, i, j] = 0.0


@njit(cache=True)
def _kernel(q, qd, rates, L, root, frm, n_modes, eta, pose, dS, n_motions, kind, gen, gen2, qi,
            tail, order, slot, loops, depends, loop_depends, derive, fast, fastC, fastq, second,
            hess):
    n = q.shape[0]
    S = frm.shape[0]
    MM = dS.shape[1]
    KK = gen.shape[1]
    Ms = np.zeros((S, 4, 4))
    dMe = np.zeros((S, MM, 4, 4))
    dMx = np.zeros((S, KK, 4, 4))
    Md = np.zeros((S, 4, 4))
    Mdd = np.zeros((S, 4, 4))
    F = np.zeros((KK, 4, 4))
    Pw = np.zeros((KK + 1, 4, 4))
    Tw = np.zeros((KK + 1, 4, 4))
    w4 = np.zeros((11, 4, 4))
    hv = np.zeros((MM, 3))
    _fast_steps(q, qd, rates, fast, fastC, fastq, Ms, dMx, Md, Mdd)
    for s in range(S):
        if fast[s] >= 0:
            continue
        _step(s, q, qd, rates, n_modes, eta, pose, dS, n_motions, kind, gen, gen2, qi, tail,
              second, hess, Ms[s], dMe[s], dMx[s], Md[s], Mdd[s], F, Pw, Tw, w4[0], w4[1],
              w4[2], w4[3], w4[4], w4[5], w4[6], w4[7], w4[8], w4[9], w4[10], hv)
    A = np.zeros((L, 4, 4))
    dA = np.zeros((L, n, 4, 4))
    Ad = np.zeros((L, 4, 4))
    Add = np.zeros((L, 4, 4))
    A[root] = np.eye(4)
    # the (., 4, 4) forms _place indexes without slicing
    dA3, dMe3, dMx3 = dA.reshape(L * n, 4, 4), dMe.reshape(S * MM, 4, 4), \
        dMx.reshape(S * KK, 4, 4)
    for li in order:
        s = slot[li]
        _place(frm[s], s, A, dA3, n, n_modes, eta, n_motions, qi, Ms, dMe3, MM, dMx3, KK, A,
               dA3, n, li, depends, derive[li])
        if rates:
            _place_rates(frm[s], s, A, Ad, Add, Ms, Md, Mdd, Ad, Add, li)
    K = loops.shape[0]
    r = np.zeros(6 * K)
    J = np.zeros((6 * K, n))
    g = np.zeros(6 * K)
    P = np.zeros((2, 4, 4))
    dP = np.zeros((2 * n, 4, 4))  # side 0's derivatives, then side 1's
    Pd = np.zeros((2, 4, 4))
    Pdd = np.zeros((2, 4, 4))
    E = np.zeros((3, 3))
    col = np.zeros(3)
    for kk in range(K):
        for side in range(2):
            s = loops[kk, side]
            _place(frm[s], s, A, dA3, n, n_modes, eta, n_motions, qi, Ms, dMe3, MM, dMx3, KK, P,
                   dP, n, side, depends, True)
            if rates:
                _place_rates(frm[s], s, A, Ad, Add, Ms, Md, Mdd, Pd, Pdd, side)
        o = 6 * kk
        for c in range(3):
            r[o + c] = P[0, c, 3] - P[1, c, 3]
        E[:] = 0.0
        _abt_add(P, 1, P, 0, 1.0, E)  # R_R R_L^T
        _vee_into(E, r, o + 3, 1.0)
        for i in range(n):
            if not loop_depends[kk, i]:
                continue
            for c in range(3):
                J[o + c, i] = dP[i, c, 3] - dP[n + i, c, 3]
            E[:] = 0.0
            _abt_add(dP, n + i, P, 0, 1.0, E)
            _abt_add(P, 1, dP, i, 1.0, E)
            _vee_into(E, col, 0, 1.0)
            for c in range(3):
                J[o + 3 + c, i] = col[c]
        if rates:
            for c in range(3):
                g[o + c] = Pdd[1, c, 3] - Pdd[0, c, 3]
            E[:] = 0.0
            _abt_add(Pdd, 1, P, 0, 1.0, E)
            _abt_add(Pd, 1, Pd, 0, 2.0, E)
            _abt_add(P, 1, Pdd, 0, 1.0, E)
            _vee_into(E, g, o + 3, -1.0)
    return A, dA, Ad, Add, r, J, g


@njit(cache=True)
def _values_kernel(q, qd, rates, need_d, A, dA, Ad, Add, frm, n_modes, eta, pose, dS,
                   n_motions, kind, gen, gen2, qi, tail, fast, fastC, fastq, second, hess):
    """P, dP, Pd, Pdd of each step (see :func:`step_values`); the same local evaluation
    (:func:`_step`, :func:`_fast_steps`) and placement (:func:`_place`) as the tree's."""
    n = q.shape[0]
    S = frm.shape[0]
    MM = dS.shape[1]
    KK = gen.shape[1]
    P = np.zeros((S, 4, 4))
    dP = np.zeros((S if need_d else 0, n, 4, 4))
    Pd = np.zeros((S, 4, 4))
    Pdd = np.zeros((S, 4, 4))
    depends = np.ones((A.shape[0], n), dtype=np.bool_)  # any link: dP from its dA
    Ms = np.zeros((S, 4, 4))
    dMe = np.zeros((S, MM, 4, 4))
    dMx = np.zeros((S, KK, 4, 4))
    Md = np.zeros((S, 4, 4))
    Mdd = np.zeros((S, 4, 4))
    F = np.zeros((KK, 4, 4))
    Pw = np.zeros((KK + 1, 4, 4))
    Tw = np.zeros((KK + 1, 4, 4))
    w4 = np.zeros((11, 4, 4))
    hv = np.zeros((MM, 3))
    dPs = np.zeros((n, 4, 4))  # without derivatives: the own columns' scratch (unread)
    nd = dA.shape[1]
    dA3, dMe3, dMx3 = dA.reshape(A.shape[0] * nd, 4, 4), dMe.reshape(S * MM, 4, 4), \
        dMx.reshape(S * KK, 4, 4)
    dP3 = dP.reshape(dP.shape[0] * n, 4, 4)
    _fast_steps(q, qd, rates, fast, fastC, fastq, Ms, dMx, Md, Mdd)
    for s in range(S):
        if fast[s] < 0:
            _step(s, q, qd, rates, n_modes, eta, pose, dS, n_motions, kind, gen, gen2, qi,
                  tail, second, hess, Ms[s], dMe[s], dMx[s], Md[s], Mdd[s], F, Pw, Tw, w4[0],
                  w4[1], w4[2], w4[3], w4[4], w4[5], w4[6], w4[7], w4[8], w4[9], w4[10], hv)
        if need_d:
            _place(frm[s], s, A, dA3, nd, n_modes, eta, n_motions, qi, Ms, dMe3, MM, dMx3, KK,
                   P, dP3, n, s, depends, True)
        else:
            _place(frm[s], s, A, dA3, nd, n_modes, eta, n_motions, qi, Ms, dMe3, MM, dMx3, KK,
                   P, dPs, 0, s, depends, True)
        if rates:
            _place_rates(frm[s], s, A, Ad, Add, Ms, Md, Mdd, Pd, Pdd, s)
    return P, dP, Pd, Pdd
