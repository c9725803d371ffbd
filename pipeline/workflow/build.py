"""Workflow spec -> machine: reduced links, mechanism, bodies, drivers, forces, initial state.

This is where names meet: every ``link.frame``, coordinate and force field is
checked here and a mistake is reported with the workflow file, line and YAML
path. Reduced links are cached under ``<cache>/<spec name>-<hash>.npz`` so a
quick and a full run, or two workflows, never overwrite each other's artifacts.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from pipeline.core.errors import ConfigError, PipelineError
from pipeline.dynamics import BodyMass, System, body_from_reduced
from pipeline.dynamics.bodies import FrameView, frame_views, in_plane_modes
from pipeline.dynamics.forces import FORCES
from pipeline.dynamics.inertia_check import motion_without_inertia
from pipeline.kinematics import Joint, build_mechanism, evaluate_tree, rigid_link
from pipeline.kinematics.drivers import driver_from_dict
from pipeline.kinematics.initial import initial_positions, initial_velocities, reach
from pipeline.kinematics.links import link_from_frames
from pipeline.workflow.link_build import frame_axes, reduce_cached
from pipeline.workflow.link_spec import LinkSpec
from pipeline.workflow.load import Workflow
from pipeline.workflow.model_checks import basis_warnings, held_mode_notes
from pipeline.workflow.overrides import apply_overrides
from pipeline.workflow.schema import MARKER_FIELDS, inertia_matrix, inertia_note
from pipeline.workflow.yaml_io import _yaml_path, error_lines, error_message, load_yaml

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class FlexPart:
    """A reduced link as used in the machine: the artifact and the kept mode indices."""

    reduced: Any  # ReducedLink
    modes: tuple[int, ...]
    cache: str  # hit | miss | corrupt | rebuilt


@dataclass(frozen=True)
class Machine:
    """The built machine of a workflow.

    Attributes
    ----------
    workflow : the Workflow it came from.  system : pipeline.dynamics.System.
    q0 : (n,) assembled initial coordinates (drivers at t = 0).  qd0 : (n,) initial rates.
    parts : link name -> FlexPart for links built from a link spec (flexible or meshed rigid).
    model_warnings : what the model cannot represent of what the machine asks of it, one
        line each (:mod:`pipeline.workflow.model_checks`); the analyses that depend on the
        flexible links are then ``suspect``.
    model_notes : facts about the model worth knowing that are no finding by themselves
        (modal motions the loops hold at zero), one line each.
    """

    workflow: Workflow
    system: System
    q0: np.ndarray
    qd0: np.ndarray
    parts: dict = field(default_factory=dict)
    model_warnings: tuple[str, ...] = ()
    model_notes: tuple[str, ...] = ()

    @property
    def mechanism(self):
        return self.system.mechanism


def frame_pose(f, where: str) -> np.ndarray:
    """(4, 4) pose of a FrameSpec (origin m, axes from z and x)."""
    T = np.eye(4)
    T[:3, 3] = f.origin
    if f.z is not None or f.x is not None:
        try:
            T[:3, :3] = frame_axes(f.z if f.z is not None else [0.0, 0.0, 1.0], f.x)
        except (ConfigError, FloatingPointError, ZeroDivisionError) as exc:
            raise ConfigError(f"{where}: {exc}") from None
    return T


def _link_spec(wf: Workflow, name: str, entry) -> tuple[LinkSpec, Path]:
    """The link spec of a link entry (file or inline) with ``spec_overrides`` applied."""
    where = wf.where("links", name, "spec")
    if isinstance(entry.spec, LinkSpec) and not entry.spec_overrides:
        return entry.spec, wf.base_dir
    if isinstance(entry.spec, LinkSpec):
        data, path, lines = entry.spec.model_dump(mode="json", exclude_none=True), wf.path, wf.lines
        base = wf.base_dir
    else:
        path = (wf.base_dir / entry.spec).resolve()
        if not path.is_file():
            raise ConfigError(f"{where}: link spec file {str(path)!r} not found")
        data, lines = load_yaml(path)
        base = path.parent
    data = apply_overrides(data, entry.spec_overrides,
                           f"{wf.where('links', name, 'spec_overrides')}")
    try:
        return LinkSpec.model_validate(data), base
    except ValidationError as exc:
        # an error in an overridden value is the workflow's line, not the spec's
        over = {tuple(k.split(".")): k for k in entry.spec_overrides}
        msgs, rest = [], []
        for err in exc.errors():
            loc = _yaml_path(tuple(err["loc"]), data)
            key = next((k for o, k in over.items()
                        if loc and (loc[:len(o)] == o or o[:len(loc)] == loc)), None)
            if key is None:
                rest.append(err)
            else:
                msgs.append(f"{wf.where('links', name, 'spec_overrides', key)}: "
                            f"{error_message(err)}")
        raise ConfigError("\n".join(msgs + error_lines(rest, path, data, lines))) from None


def kept_modes(reduced, modes, plane: str | None, tol: float = 1e-2) -> tuple[int, ...]:
    """Indices of the kept modes: a count (lowest n), indices, or a rule (an object with
    ``f_max``, ``effective_mass``, ``directions``, ``interface``, ``count``, see
    :class:`pipeline.workflow.schema.ModeSelection`), optionally only those that move in
    ``plane`` (:func:`pipeline.dynamics.bodies.in_plane_modes`, frame test at ``tol``)."""
    candidates = list(range(reduced.n_modes)) if plane is None else list(
        in_plane_modes(reduced, plane, tol))
    if modes is None:
        return tuple(candidates)
    if not isinstance(modes, int | list | tuple):
        return _selected(reduced, candidates, modes, plane)
    if isinstance(modes, int):
        if modes > len(candidates):
            raise ConfigError(f"modes: {modes} requested, {len(candidates)} available"
                              + (f" in plane {plane}" if plane else "")
                              + f" (the spec computes {reduced.n_modes}; raise its modes.count)")
        return tuple(candidates[:modes])
    bad = [m for m in modes if m not in candidates]
    if bad:
        raise ConfigError(f"modes: indices {bad} not available; available: {candidates}")
    return tuple(modes)


def _selected(reduced, candidates: list[int], rule, plane) -> tuple[int, ...]:
    """The modes of ``candidates`` a ModeSelection keeps (see :func:`kept_modes`)."""
    from pipeline.invariants.participation import DIRECTIONS, effective_mass_fractions

    f = np.asarray(reduced.frequencies_hz)
    keep = [a for a in candidates if rule.f_max is None or f[a] <= rule.f_max]
    if rule.effective_mass is not None:
        try:
            frac = effective_mass_fractions(reduced, rule.interface)
        except KeyError as exc:
            raise ConfigError(f"modes.interface: {exc.args[0]}") from None
        target = rule.effective_mass
        reach = frac[keep].sum(axis=0)
        if rule.directions is None:
            dirs = [k for k in range(6) if reach[k] >= target]
            if not dirs:
                raise ConfigError(f"modes.effective_mass: no direction reaches {target:g} with "
                                  f"the {len(keep)} modes available (best "
                                  f"{DIRECTIONS[int(np.argmax(reach))]}: {reach.max():.3f}); "
                                  f"raise the spec's modes.count")
        else:
            dirs = [DIRECTIONS.index(d) for d in rule.directions]
            short = [f"{DIRECTIONS[k]} {reach[k]:.3f}" for k in dirs if reach[k] < target]
            if short:
                raise ConfigError(f"modes.effective_mass: {target:g} not reached with the "
                                  f"{len(keep)} modes available (" + ", ".join(short) +
                                  "); raise the spec's modes.count or lower the fraction")
        cum = np.cumsum(frac[keep][:, dirs], axis=0)
        n = int(np.argmax(np.all(cum >= target - 1e-12, axis=1))) + 1
        keep = keep[:n]
    if rule.count is not None:
        keep = keep[:rule.count]
    if not keep:
        raise ConfigError("modes: the rule keeps no mode" + (f" in plane {plane}" if plane
                                                             else ""))
    return tuple(keep)


def _flex_frames(reduced, idx, plane, extra, where_frames, second_order: bool = False
                 ) -> list[FrameView]:
    """Frames of a reduced link restricted to the kept modes, plus the workflow's extra
    frames fixed on them (:func:`pipeline.dynamics.bodies.frame_views`)."""
    fixed = {new: (fs.on, frame_pose(fs, f"{where_frames}.{new}")) for new, fs in extra.items()}
    return frame_views(reduced, idx, plane, second_order, fixed, where_frames)


#: suffixes of a ``spec`` that is a reduced link in the documented HDF5 format (written by
#: ``pipeline reduce --hdf5`` or by another tool, docs/hdf5_format.md): read, not reduced
REDUCED_FILES = (".h5", ".hdf5")


def is_reduced_file(spec) -> bool:
    """Whether a link entry's ``spec`` names a reduced link file (:data:`REDUCED_FILES`)."""
    return isinstance(spec, str) and Path(spec).suffix.lower() in REDUCED_FILES


def _read_reduced(wf: Workflow, name: str, entry):
    """The reduced link of a ``spec: <file>.h5`` entry, as the file holds it."""
    from pipeline.invariants.hdf5 import read_hdf5

    path = (wf.base_dir / entry.spec).resolve()
    if entry.spec_overrides:
        raise wf.error("links", name, "spec_overrides",
                       msg="a reduced link read from a file is used as it is; change its "
                           "spec and reduce it again instead")
    if not path.is_file():
        raise wf.error("links", name, "spec", msg=f"reduced link file {str(path)!r} not found")
    try:
        link = read_hdf5(path)
    except PipelineError as exc:
        raise wf.error("links", name, "spec", msg=str(exc)) from None
    if getattr(entry, "geometric_stiffening", False) and \
            link.force_geometric_stiffness.shape[0] == 0:
        raise wf.error("links", name, "geometric_stiffening",
                       msg=f"{path.name} holds no geometric stiffness (reduce its spec with "
                           "modes.geometric_stiffening: true and export it again)")
    return link, "file"


def _reduce(wf: Workflow, name: str, entry, cache_dir: Path, rebuild: bool):
    if is_reduced_file(entry.spec):
        return _read_reduced(wf, name, entry)
    spec, base = _link_spec(wf, name, entry)
    if getattr(entry, "geometric_stiffening", False):
        spec = spec.model_copy(update={"modes": spec.modes.model_copy(
            update={"geometric_stiffening": True})})
    spec_file = None if isinstance(entry.spec, LinkSpec) else (wf.base_dir / entry.spec)
    try:
        link, status, _ = reduce_cached(spec, base, cache_dir, rebuild, spec_file)
    except PipelineError as exc:
        raise type(exc)(f"{wf.where('links', name, 'spec')}: {exc}") from exc
    return link, status


def build_links(wf: Workflow, cache_dir: Path, rebuild: bool = False):
    """(kinematics links, bodies, parts) of every link entry."""
    links, bodies, parts = [], {}, {}
    for name, entry in wf.spec.links.items():
        where = wf.where("links", name)
        if entry.type == "ground":
            frames = {k: frame_pose(f, wf.where("links", name, "frames", k))
                      for k, f in entry.frames.items()}
            links.append(rigid_link(name, frames))
            continue
        if entry.spec is None:  # rigid with given mass properties
            frames = {k: frame_pose(f, wf.where("links", name, "frames", k))
                      for k, f in entry.frames.items()}
            links.append(rigid_link(name, frames))
            if entry.mass is None:
                continue  # massless intermediate link
            com = entry.com if entry.com is not None else [0.0, 0.0, 0.0]
            try:
                bodies[name] = BodyMass.rigid(entry.mass, com, inertia_matrix(entry.inertia))
            except ConfigError as exc:
                raise ConfigError(f"{where}: {exc}") from None
            note = inertia_note(inertia_matrix(entry.inertia))
            if note:
                logger.info("%s.inertia: %s; accepted: the machine is checked to have inertia "
                            "for every motion its joints allow", where, note)
            continue
        red, status = _reduce(wf, name, entry, cache_dir, rebuild)
        plane = getattr(entry, "plane", None)
        try:
            idx = kept_modes(red, getattr(entry, "modes", 0) if entry.type == "flexible" else 0,
                             plane)
        except ConfigError as exc:
            raise ConfigError(f"{where}.{exc}") from None
        extra = entry.frames
        if entry.type == "rigid":
            extra = {k: v for k, v in entry.frames.items()}
            for k, v in extra.items():
                if v.on is None:
                    raise wf.error("links", name, "frames", k, "on",
                                   msg="a frame on a meshed link needs `on:` (a spec interface "
                                       "or marker)")
        views = _flex_frames(red, idx, plane, extra, f"{where}.frames",
                             bool(getattr(entry, "geometric_stiffening", False)))
        links.append(link_from_frames(name, views))
        if idx:
            d = entry.damping
            try:
                bodies[name] = body_from_reduced(
                    red, list(idx), damping_ratios=None if d is None else (
                        d.ratios if d.ratios is not None else
                        ([d.ratio] * len(idx) if d.ratio is not None else None)),
                    rayleigh=None if d is None else d.rayleigh,
                    second_order=bool(getattr(entry, "geometric_stiffening", False)),
                    plane=plane)
            except ConfigError as exc:
                raise ConfigError(f"{where}: {exc}") from None
        else:
            bodies[name] = BodyMass(C=np.array(red.C, dtype=float))
        parts[name] = FlexPart(red, idx, status)
    return links, bodies, parts


def _split(wf: Workflow, value: str, *path) -> tuple[str, str]:
    link, _, frame = value.partition(".")
    if link not in wf.spec.links or not frame:
        raise wf.error(*path, msg=f"expected 'link.frame' with link one of "
                                  f"{sorted(wf.spec.links)}, got {value!r}")
    return link, frame


#: joints that leave the rotation of a link's end free about their axes, enough of it for
#: a chord reference (the end rotates about the pin relative to the chord)
PIN_JOINTS = ("revolute", "spherical")


def build_joints(wf: Workflow, links, parts=None) -> list[Joint]:
    frames = {l.name: [f.name for f in l.frames] for l in links}
    chord_pins = {name: p.reduced.frames[0].name for name, p in (parts or {}).items()
                  if p.reduced.chord is not None}
    joints = []
    for i, j in enumerate(wf.spec.joints):
        sides = []
        for side in ("parent", "child"):
            link, frame = _split(wf, getattr(j, side), "joints", i, side)
            if frame not in frames[link]:
                raise wf.error("joints", i, side, msg=f"link {link!r} has no frame {frame!r}; "
                                                      f"frames: {frames[link]}")
            if chord_pins.get(link) == frame and j.type not in PIN_JOINTS:
                raise wf.error("joints", i, "type", msg=(
                    f"link {link!r} has a chord reference (modes.chord): its frame "
                    f"{frame!r} follows the chord, not the end, so only a pin "
                    f"({' or '.join(PIN_JOINTS)}) may join it there, not {j.type!r}; "
                    "use clamped modes for a fixed end"))
            sides += [link, frame]
        try:
            joints.append(Joint(j.name, j.type, sides[0], sides[1], sides[2], sides[3],
                                tuple(j.initial)))
        except ConfigError as exc:
            raise wf.error("joints", i, msg=str(exc)) from None
    return joints


def _coordinate(wf: Workflow, mech, name: str, *path) -> int:
    if name not in mech.coordinates:
        raise wf.error(*path, msg=f"coordinate {name!r} does not exist; coordinates: "
                                  f"{list(mech.coordinates)}")
    return mech.index(name)


def build_drivers(wf: Workflow, mech) -> dict:
    out = {}
    for key, d in wf.spec.drivers.items():
        _coordinate(wf, mech, key, "drivers", key)
        out[key] = driver_from_dict(d, wf.where("drivers", key), wf.base_dir)
    return out


def _element_kwargs(wf: Workflow, mech, i: int, f) -> dict:
    kw = dict(f.model_extra or {})
    for key in MARKER_FIELDS:
        if key in kw:
            if not isinstance(kw[key], str):
                raise wf.error("forces", i, key, msg=f"expected 'link.frame', got {kw[key]!r}")
            link, frame = _split(wf, kw[key], "forces", i, key)
            names = [fr.name for fr in mech.links[mech.link_index(link)].frames]
            if frame not in names:
                raise wf.error("forces", i, key, msg=f"link {link!r} has no frame {frame!r}; "
                                                     f"frames: {names}")
            kw[key] = (link, frame)
    if "coordinate" in kw:
        _coordinate(wf, mech, str(kw["coordinate"]), "forces", i, "coordinate")
    field = getattr(FORCES.get(f.type), "HISTORY", "history")  # a valve's is "command"
    if f.type == "hydraulic_cylinder" and isinstance(kw.get(field), dict) \
            and "pid" in kw[field]:
        kw[field] = _pid(wf, mech, kw[field], ("forces", i, field))
    elif isinstance(kw.get(field), dict):
        kw[field] = driver_from_dict(kw[field], wf.where("forces", i, field), wf.base_dir)
    return kw


def _pid(wf: Workflow, mech, spec: dict, path: tuple):
    """The PID controller of a cylinder's ``command: {pid: {...}}`` (its reference a
    number or a driver, as a command's)."""
    from pipeline.dynamics.forces.hydraulics import PID

    if set(spec) != {"pid"} or not isinstance(spec["pid"], dict):
        raise wf.error(*path, msg="expected {pid: {reference, kp, ki, kd, measured, "
                                  "output_limits, tracking_time}}")
    kw = dict(spec["pid"])
    fields = [x.name for x in dataclasses.fields(PID)]
    unknown = sorted(set(kw) - set(fields))
    if unknown:
        raise wf.error(*path, "pid", unknown[0],
                       msg=f"unknown field of a PID (misspelt?); fields: {fields}")
    for key in ("reference", "kp"):
        if key not in kw:
            raise wf.error(*path, "pid", msg=f"missing field {key!r}")
    if isinstance(kw["reference"], dict):
        kw["reference"] = driver_from_dict(kw["reference"], wf.where(*path, "pid", "reference"),
                                           wf.base_dir)
    measured = str(kw.get("measured", "stroke"))
    if measured.startswith("marker:"):
        _measured_marker(wf, mech, measured, (*path, "pid", "measured"))
    elif measured not in ("stroke", "p_a", "p_b"):
        _coordinate(wf, mech, measured, *path, "pid", "measured")
    if isinstance(kw.get("output_limits"), list):
        kw["output_limits"] = tuple(kw["output_limits"])
    try:
        return PID(**kw)
    except ConfigError as exc:
        raise wf.error(*path, "pid", msg=str(exc)) from None


def _measured_marker(wf: Workflow, mech, measured: str, path: tuple) -> None:
    """A controller's "marker:link.frame:x|y|z": its link and frame must exist."""
    from pipeline.dynamics.forces.hydraulics import marker_measurement

    try:
        link, frame, _ = marker_measurement(measured)
        mech.marker(link, frame)
    except ConfigError as exc:
        raise wf.error(*path, msg=str(exc)) from None


def _marker_distance(mech, q, a, b) -> float:
    from pipeline.dynamics.forces.base import marker_pose

    tree = evaluate_tree(mech, q, derivatives=False)
    stub = type("S", (), {"mechanism": mech})()
    pa, pb = (marker_pose(stub, *m, tree, q)[:3, 3] for m in (a, b))
    return float(np.linalg.norm(pb - pa))


def build_forces(wf: Workflow, mech, q0) -> list:
    out = []
    for i, f in enumerate(wf.spec.forces):
        if f.type not in FORCES:
            raise wf.error("forces", i, "type", msg=f"expected one of {sorted(FORCES)}, "
                                                    f"got {f.type!r}")
        cls = FORCES[f.type]
        kw = _element_kwargs(wf, mech, i, f)
        if kw.get("free_length") == "initial":
            if "marker_a" not in kw or "marker_b" not in kw:
                raise wf.error("forces", i, "free_length",
                               msg="'initial' needs marker_a and marker_b")
            kw["free_length"] = _marker_distance(mech, q0, kw["marker_a"], kw["marker_b"])
        fields = [x.name for x in dataclasses.fields(cls) if x.name != "name"]
        unknown = sorted(set(kw) - set(fields))
        if unknown:
            raise wf.error("forces", i, unknown[0],
                           msg=f"unknown field for a {f.type} (misspelt?); fields: {fields}")
        try:
            out.append(cls(name=f.name, **kw))
        except TypeError as exc:
            raise wf.error("forces", i, msg=f"{exc}; fields of {f.type}: {fields}") from None
        except ConfigError as exc:
            raise wf.error("forces", i, msg=str(exc)) from None
    return out


def initial_state(wf: Workflow, mech, drivers, init=None, path=("initial",)):
    """(q0, qd0) consistent with the loops and the drivers at t = 0: the joints' ``initial``
    values are the approximate assembly; the ``initial:`` coordinates and velocities
    (``init``, default the workflow's) are honoured exactly where the loops allow, projected
    by least squares where they over-determine them, and a value that cannot be honoured is
    an error naming it (:mod:`pipeline.kinematics.initial`)."""
    init = wf.spec.initial if init is None else init
    for key in init.coordinates:
        _coordinate(wf, mech, key, *path, "coordinates", key)
    for key in init.velocities:
        _coordinate(wf, mech, key, *path, "velocities", key)
    driven = {k: float(d.value(0.0)) for k, d in drivers.items()}
    rates = {k: float(d.rate(0.0)) for k, d in drivers.items()}
    for group, given in (("coordinates", init.coordinates), ("velocities", init.velocities)):
        both = sorted(set(given) & set(driven))
        if both:
            raise wf.error(*path, group, both[0], msg="a driven coordinate's initial value "
                           "comes from its driver; remove it here")
    try:
        q = initial_positions(mech, mech.q_initial, driven, dict(init.coordinates))
    except PipelineError as exc:
        out_of_reach(wf, mech, driven)
        where = (*path, "coordinates") if init.coordinates else path
        raise wf.error(*where, msg=f"cannot assemble the machine at t = 0: {exc}") from None
    try:
        qd = initial_velocities(mech, q, rates, dict(init.velocities))
    except PipelineError as exc:
        raise wf.error(*path, "velocities", msg=str(exc)) from None
    return q, qd


def out_of_reach(wf: Workflow, mech, driven: dict[str, float]) -> None:
    """Raise, at the driver's line, for a driver whose value at t = 0 the loops cannot
    reach with the other drivers at theirs: its value and the range that closes
    (:func:`pipeline.kinematics.initial.reach`). Returns if every driver is within reach
    on its own (the failure is elsewhere)."""
    if not mech.topology.loops:
        return
    for name, value in driven.items():
        span = reach(mech, mech.q_initial, driven, name)
        if span is None or span[0] <= value <= span[1]:
            continue
        unit = "m" if mech.translations[mech.index(name)] else "rad"
        others = ", ".join(f"{k} = {v:.6g}" for k, v in driven.items() if k != name)
        raise wf.error("drivers", name, msg=(
            f"{name} = {value:.6g} {unit} at t = 0 is out of reach: the loops close only "
            f"for {name} from {span[0]:.6g} to {span[1]:.6g} {unit}"
            + (f" (with {others})" if others else "") + "; change the driver's value at "
            "t = 0 or the geometry (joint frames, link lengths)")) from None


def build_machine(wf: Workflow, cache_dir: str | Path | None = None,
                  rebuild: bool = False) -> Machine:
    """Reduce the links (cached in ``cache_dir``, default the shared link cache of
    :func:`pipeline.invariants.cache.default_links_dir`), build mechanism, bodies, drivers,
    forces; assemble at t = 0.

    Raises
    ------
    ConfigError
        Any inconsistency, named by workflow file, line and YAML path.
    """
    if cache_dir is None:
        from pipeline.invariants.cache import default_links_dir

        cache_dir = default_links_dir()
    links, bodies, parts = build_links(wf, Path(cache_dir), rebuild)
    joints = build_joints(wf, links, parts)
    try:
        mech = build_mechanism(links, joints)
    except ConfigError as exc:
        raise wf.error("joints", msg=str(exc)) from None
    drivers = build_drivers(wf, mech)
    q0, qd0 = initial_state(wf, mech, drivers)
    forces = build_forces(wf, mech, q0)
    system = System(mech, bodies, wf.spec.gravity, forces=forces, drivers=drivers)
    coords, moving = motion_without_inertia(system, q0)
    if coords:
        where = ("links", moving[0], "inertia") if moving else ("links",)
        raise wf.error(*where, msg=(
            f"the machine has no inertia for a motion its joints allow at t = 0: moving "
            f"{', '.join(coords)} moves {', '.join(repr(n) for n in moving)} without "
            "kinetic energy (a link without inertia about an axis a joint lets it turn "
            "about, or a massless link a joint lets move); give those links inertia for "
            "that motion or hold it with a joint"))
    machine = Machine(wf, system, q0, qd0, parts)
    return dataclasses.replace(machine, model_warnings=basis_warnings(wf, machine),
                               model_notes=held_mode_notes(wf, machine))
