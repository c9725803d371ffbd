"""Named histories of an analysis result: ``kind:target[:component]`` -> values, label, unit.

=======================  ==============================================  ==========
series                   meaning                                         unit
=======================  ==============================================  ==========
time                     output time                                     s
q:J1.theta (qd:, qdd:)   coordinate (rate, acceleration)                 rad, m
marker:link.frame:z      marker origin in ground (x, y, z, norm)         m
deflection:link.frame:z  elastic displacement of the marker, ground axes  m
deflection:l.f:y@link    x, y, z in the body axes of ``link`` (a
                         deflection in its own link's axes is signed and
                         free of the link's rotation)
energy:total             kinetic, gravity, elastic, forces, dissipated,  J
                         driver_work (dynamic runs); total: its change
                         since the start, the balance's drift (zero in
                         an exact run)
driver_force:LCYL.d      force a driver/held coordinate applies          N, N m
state:boom_cyl.p_a       a force element's own state (a hydraulic        Pa
                         cylinder's chamber pressure; dynamic runs)
reaction:J1:fy           joint reaction on the child link at the joint   N, N m
                         point, ground axes (fx fy fz mx my mz, force,
                         moment: norms; kinetostatic with reactions)
stress:link.frame:von_mises  stress at the link node nearest the frame     Pa
                         (solids: von_mises, s1, s2, s3 principal, xx
                         yy zz yz xz xy body axes; beams: section
                         resultants N Vy Vz T My Mz, element axes)       N, N m
frequency                linearised natural frequencies (x: mode no.)    Hz
=======================  ==============================================  ==========
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.fem.stress import RESULTANTS, VOIGT, principal_stresses, von_mises
from pipeline.kinematics import evaluate_tree
from pipeline.kinematics.marker_names import AXES, marker_component
from pipeline.kinematics.poses import step_pose

KINDS = ("time", "q", "qd", "qdd", "marker", "deflection", "energy", "driver_force",
         "reaction", "stress", "frequency", "state")
SOLID_STRESS = ("von_mises", "s1", "s2", "s3", *VOIGT)
BEAM_STRESS = RESULTANTS
REACTION_COMPONENTS = ("fx", "fy", "fz", "mx", "my", "mz", "force", "moment")
_COMPONENT = {"x": 0, "y": 1, "z": 2}


@dataclass(frozen=True)
class Series:
    values: np.ndarray
    label: str
    unit: str


def coordinate_unit(name: str, order: int = 0) -> str:
    """The unit of coordinate ``name`` (rad, m or - for a modal one), of its rate
    (``order`` 1) or acceleration (2)."""
    var = name.rsplit(".", 1)[-1]
    base = "rad" if var in ("theta", "alpha", "beta", "rx", "ry", "rz") else (
        "-" if var.startswith("eta") else "m")
    return base + ("", "/s", "/s²")[order]


def marker_positions(mech, q: np.ndarray, link: str, frame: str, elastic_only: bool = False,
                     axes: str | None = None):
    """(T, 3) position of marker ``link.frame`` over the rows of q (T, n), m; with
    ``elastic_only`` the displacement due to the link's own modal coordinates.

    Ground axes by default; with ``axes`` (a link name) in that link's body axes, a
    position relative to its origin. A deflection in its own link's axes is the modal
    displacement of the marker in the body frame: signed, and free of the link's rigid
    rotation.
    """
    step = mech.marker(link, frame)
    li = mech.link_index(link)
    ai = None if axes is None else mech.link_index(axes)
    out = np.empty((q.shape[0], 3))
    for k, qk in enumerate(q):
        poses = evaluate_tree(mech, qk, derivatives=False).A
        p = step_pose(step, poses, qk)[:3, 3]
        if elastic_only:
            q0 = qk.copy()
            q0[mech.modal_index[li]] = 0.0
            p = p - step_pose(step, poses, q0)[:3, 3]
        if ai is not None:
            B = poses[ai]
            p = B[:3, :3].T @ (p if elastic_only else p - B[:3, 3])
        out[k] = p
    return out


def _marker_parts(spec: str, rest: str, mech) -> tuple[str, str, str | None]:
    """(link.frame, component, axes link or None) of ``link.frame[:comp[@axes]]``
    (:func:`pipeline.kinematics.marker_names.marker_component`)."""
    try:
        link, frame, axis, axes = marker_component(rest, norm=True, axes=True)
    except ValueError as exc:
        raise ConfigError(f"series {spec!r}: {exc}") from None
    if axes and axes not in mech.link_names:
        raise ConfigError(f"series {spec!r}: axes {axes!r}: expected a link of "
                          f"{list(mech.link_names)}")
    return f"{link}.{frame}", "norm" if axis is None else AXES[axis], axes


def series(result, mech, spec: str, parts=None) -> Series:
    """Values (T,) of ``spec`` in ``result`` (an AnalysisResult of ``mech``); ``parts``
    (the machine's reduced links, ``Machine.parts``) for stress series.

    Raises
    ------
    ConfigError
        Unknown kind, target or component, or a kind the analysis does not produce.
    """
    kind, _, rest = spec.partition(":")
    if kind not in KINDS:
        raise ConfigError(f"series {spec!r}: kind {kind!r} is not one of {list(KINDS)}")
    if kind == "time":
        return Series(result.t, "time", "s")
    if kind in ("q", "qd", "qdd"):
        if rest not in result.coordinates:
            raise ConfigError(f"series {spec!r}: coordinate {rest!r} does not exist; "
                              f"coordinates: {list(result.coordinates)}")
        order = ("q", "qd", "qdd").index(kind)
        arr = (result.q, result.qd, result.qdd)[order]
        return Series(arr[:, result.coordinates.index(rest)],
                      rest + ("", " rate", " acceleration")[order], coordinate_unit(rest, order))
    if kind in ("marker", "deflection"):
        target, comp, axes = _marker_parts(spec, rest, mech)
        link, _, frame = target.partition(".")
        try:
            P = marker_positions(mech, result.q, link, frame,
                                 elastic_only=kind == "deflection", axes=axes)
        except (ConfigError, KeyError, ValueError) as exc:
            raise ConfigError(f"series {spec!r}: expected an existing link.frame: {exc}") \
                from None
        v = np.linalg.norm(P, axis=1) if comp == "norm" else P[:, _COMPONENT[comp]]
        what = "elastic deflection" if kind == "deflection" else "position"
        where = f" ({axes} axes)" if axes else ""
        return Series(v, f"{target} {what} {comp}{where}", "m")
    if kind == "energy":
        if not result.energies:
            raise ConfigError(f"series {spec!r}: analysis '{result.name}' ({result.type}) has no "
                              "energies (dynamic analyses do)")
        if rest not in result.energies:
            raise ConfigError(f"series {spec!r}: expected one of {sorted(result.energies)}")
        e = np.asarray(result.energies[rest], dtype=float)
        if rest == "total":  # conserved: what a reader looks for is its drift, not its level
            return Series(e - e[0], "total energy change since the start (drift)", "J")
        return Series(e, f"{rest} energy", "J")
    if kind == "driver_force":
        if rest not in result.forces:
            raise ConfigError(f"series {spec!r}: analysis '{result.name}' has actuator forces "
                              f"for {sorted(result.forces)}")
        unit = "N m" if coordinate_unit(rest, 0) == "rad" else "N"
        return Series(np.asarray(result.forces[rest]), f"{rest} actuator force", unit)
    if kind == "reaction":
        return reaction_series(result, spec)
    if kind == "state":
        if rest not in result.states:
            raise ConfigError(f"series {spec!r}: analysis '{result.name}' has element states "
                              f"{sorted(result.states)}")
        unit, x = result.states[rest]
        return Series(np.asarray(x), rest, unit)
    if kind == "stress":
        return stress_series(result, mech, parts or {}, spec)
    f = result.extra.get("frequencies_hz")
    if f is None:
        raise ConfigError(f"series {spec!r}: only linearised analyses have frequencies")
    return Series(np.asarray(f), "natural frequency", "Hz")


def stress_series(result, mech, parts, spec: str) -> Series:
    """``stress:LINK.FRAME:QUANTITY``: the stress (or beam section resultant) at the FE node
    of the link nearest the frame's origin, from its stress modes and modal coordinates."""
    link, frame, comp, node = _stress_target(spec, mech, parts)
    part = parts[link]
    beam = part.reduced.kind == "beam"
    label = f"{link}.{frame} {comp}" if beam else \
        f"{link}.{frame} {comp.replace('_', ' ')} stress"
    unit = ("N m" if comp[0] in "TM" else "N") if beam else "Pa"
    if not part.modes:  # a case that keeps no mode: the link is rigid, its stress unknown
        return Series(np.full(len(result.t), np.nan), f"{label} (rigid case)", unit)
    S = np.asarray(part.reduced.stress_modes, dtype=float)[list(part.modes), node]  # (k, 6)
    if beam and _carried_by_none(S, RESULTANTS.index(comp)):
        # e.g. a pinned rod's axial force without its axial mode: zero whatever the loads
        return Series(np.full(len(result.t), np.nan),
                      f"{label} (none of the kept modes carries it)", unit)
    eta = result.q[:, mech.modal_index[mech.link_index(link)]]
    s = eta @ S  # (T, 6)
    if beam:
        v = s[:, RESULTANTS.index(comp)]
    elif comp == "von_mises":
        v = von_mises(s)
    elif comp in ("s1", "s2", "s3"):
        v = principal_stresses(s)[:, int(comp[1]) - 1]
    else:
        v = s[:, VOIGT.index(comp)]
    return Series(v, label, unit)


def _carried_by_none(S: np.ndarray, c: int, rtol: float = 1e-9) -> bool:
    """Whether beam resultant c of the stress modes S (k, 6) [N Vy Vz T My Mz] at a node is
    round-off in every kept mode, against the largest resultant of its kind (forces or
    moments) there: the series would read zero whatever the loads."""
    kind = slice(0, 3) if c < 3 else slice(3, 6)
    scale = np.abs(S[:, kind]).max(initial=0.0)
    return scale > 0.0 and np.abs(S[:, c]).max() <= rtol * scale


def _stress_target(spec: str, mech, parts) -> tuple[str, str, str, int]:
    _, _, rest = spec.partition(":")
    target, _, comp = rest.rpartition(":")
    link, _, frame = target.partition(".")
    part = parts.get(link)
    if link not in mech.link_names or part is None:
        flex = sorted(parts)
        raise ConfigError(f"series {spec!r}: expected stress:<link>.<frame>:<quantity> with a "
                          f"flexible link of {flex}")
    names = [f.name for f in mech.links[mech.link_index(link)].frames]
    if frame not in names:
        raise ConfigError(f"series {spec!r}: frame {frame!r} is not on link {link!r} "
                          f"(frames: {names})")
    red = part.reduced
    if not red.stress_modes.size:
        why = red.meta.get("stress", {}).get("unavailable") or \
            "reduce it again with this version"
        raise ConfigError(f"series {spec!r}: link {link!r} has no stress modes ({why})")
    allowed = BEAM_STRESS if red.kind == "beam" else SOLID_STRESS
    if comp not in allowed:
        raise ConfigError(f"series {spec!r}: quantity {comp!r}: expected one of "
                          f"{list(allowed)} for a {red.kind} link")
    origin = mech.links[mech.link_index(link)].frame(frame).pose[:3, 3]
    node = int(np.argmin(np.linalg.norm(np.asarray(red.nodes) - origin, axis=1)))
    return link, frame, comp, node


def reaction_series(result, spec: str) -> Series:
    """``reaction:JOINT:COMPONENT`` of a kinetostatic result computed with reactions."""
    _, _, rest = spec.partition(":")
    joint, _, comp = rest.partition(":")
    reactions = result.extra.get("reactions")
    if not reactions:
        raise ConfigError(f"series {spec!r}: analysis '{result.name}' has no joint reactions "
                          "(a kinetostatic analysis with reactions: true has them)")
    joints = list(reactions[0].joints)
    if joint not in joints or comp not in REACTION_COMPONENTS:
        raise ConfigError(f"series {spec!r}: expected reaction:<joint>:<component> with a joint "
                          f"of {joints} and a component of {list(REACTION_COMPONENTS)}")
    j = joints.index(joint)
    F = np.array([r.force[j] for r in reactions])
    M = np.array([r.moment[j] for r in reactions])
    if comp in ("force", "moment"):
        v = np.linalg.norm(F if comp == "force" else M, axis=1)
    else:
        v = (F if comp[0] == "f" else M)[:, _COMPONENT[comp[1]]]
    return Series(v, f"{joint} reaction {comp}", "N" if comp[0] == "f" else "N m")


def check_series(spec: str, mech, analysis_type: str, parts=None, states=None) -> None:
    """Fail early (before any analysis runs) on a series that cannot exist.

    Raises
    ------
    ConfigError
        Unknown kind, coordinate, link.frame or component, or a kind the analysis
        type does not produce.
    """
    kind, _, rest = spec.partition(":")
    if kind not in KINDS:
        raise ConfigError(f"series {spec!r}: kind {kind!r} is not one of {list(KINDS)}")
    if kind in ("q", "qd", "qdd") and rest not in mech.coordinates:
        raise ConfigError(f"series {spec!r}: coordinate {rest!r} does not exist; "
                          f"coordinates: {list(mech.coordinates)}")
    if kind in ("marker", "deflection"):
        target, _, _ = _marker_parts(spec, rest, mech)
        link, _, frame = target.partition(".")
        if link not in mech.link_names or frame not in [
                f.name for f in mech.links[mech.link_index(link)].frames]:
            raise ConfigError(f"series {spec!r}: expected an existing link.frame, got "
                              f"{target!r}")
    if kind == "stress":
        _stress_target(spec, mech, parts or {})
        if analysis_type == "linearised":
            raise ConfigError(f"series {spec!r}: linearised analyses have mode shapes, not "
                              "stress histories")
    if kind == "energy" and analysis_type != "dynamic":
        raise ConfigError(f"series {spec!r}: only dynamic analyses have energies")
    if kind == "state" and analysis_type != "dynamic":
        raise ConfigError(f"series {spec!r}: only dynamic analyses have element states")
    if kind == "state" and states is not None and rest not in states:
        raise ConfigError(f"series {spec!r}: expected a force element's state, one of "
                          f"{list(states)}")
    if kind == "frequency" and analysis_type != "linearised":
        raise ConfigError(f"series {spec!r}: only linearised analyses have frequencies")
    if kind == "reaction":
        joint, _, comp = rest.partition(":")
        names = [j.name for j in mech.joints]
        if analysis_type != "kinetostatic" or joint not in names or \
                comp not in REACTION_COMPONENTS:
            raise ConfigError(f"series {spec!r}: expected reaction:<joint>:<component> of a "
                              f"kinetostatic analysis (reactions: true), a joint of {names} and "
                              f"a component of {list(REACTION_COMPONENTS)}")
    if kind == "driver_force" and analysis_type not in ("dynamic", "kinetostatic"):
        raise ConfigError(f"series {spec!r}: only dynamic and kinetostatic analyses have "
                          "actuator forces")
