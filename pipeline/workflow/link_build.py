"""LinkSpec (YAML) -> LinkRequest (plain values) and its input hash."""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

import numpy as np

from pipeline import __version__
from pipeline.core.errors import ConfigError
from pipeline.core.hashing import content_hash
from pipeline.core.validate import validate_array
from pipeline.fem.interfaces import InterfaceSpec
from pipeline.fem.material import Material
from pipeline.fem.point_masses import PointMass
from pipeline.fem.section import BeamSection
from pipeline.invariants.reduce import LinkRequest, MarkerRequest
from pipeline.invariants.store import FORMAT_VERSION
from pipeline.meshing.budget import MeshBudget
from pipeline.meshing.geometry import BeamGeometry, SolidGeometry
from pipeline.meshing.imported import MatrixFiles, MeshFileGeometry
from pipeline.meshing.selectors import SELECTORS
from pipeline.workflow.link_spec import BUDGET_FIELDS, LinkSpec

_VERSIONED = ("numpy", "scipy", "scikit-fem", "gmsh")


def frame_axes(z_axis, x_axis=None) -> np.ndarray:
    """(3, 3) right-handed axes (columns x, y, z) with z along ``z_axis``.

    ``x_axis`` is made orthogonal to z; by default x is the global axis least
    aligned with z, orthogonalised.

    Examples
    --------
    >>> np.round(frame_axes([0, 0, 1]), 12).tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    """
    z = _direction(z_axis, "z_axis")
    x = np.eye(3)[np.argmin(np.abs(z))] if x_axis is None else _direction(x_axis, "x_axis")
    x = x - (x @ z) * z
    if np.linalg.norm(x) < 1e-9:
        raise ConfigError("x_axis: expected a direction not parallel to z_axis")
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def _direction(value, name: str) -> np.ndarray:
    """A unit (3,) vector along ``value``; scaled by its largest entry first, so that a tiny
    one (1e-320) is still a direction; zero or not finite is a ConfigError."""
    v = validate_array(value, (3,), name)
    big = float(np.abs(v).max())
    if big == 0.0:
        raise ConfigError(f"{name}: expected a direction, got the zero vector {v.tolist()}")
    v = v / big
    return v / np.linalg.norm(v)


def _interface(spec, link: str) -> InterfaceSpec:
    sel = spec.selector
    fields = sel.model_dump(exclude={"type"}, exclude_none=True)
    selector = SELECTORS[sel.type](**fields)
    origin = spec.origin if spec.origin is not None else getattr(sel, "point", None)
    if origin is None:
        raise ConfigError(f"link {link!r}: interfaces[{spec.name}].origin: required for a "
                          f"{sel.type!r} selector")
    z = spec.z_axis or getattr(sel, "axis", None) or getattr(sel, "normal", None) or [0, 0, 1]
    return InterfaceSpec(spec.name, selector, np.asarray(origin, float),
                         frame_axes(z, spec.x_axis), spec.kind)


def link_request(spec: LinkSpec, base_dir: Path) -> tuple[LinkRequest, tuple[Path, ...]]:
    """Plain request for :func:`pipeline.invariants.reduce.reduce_link` and its input files."""
    g = spec.geometry
    files: tuple[Path, ...] = ()
    budget = None
    modes_file = None if spec.modes.file is None else (base_dir / spec.modes.file).resolve()
    if g.type == "solid":
        path = None
        if g.path is not None:
            path = (base_dir / g.path).resolve()
            files = (path,) if path.is_file() else ()
        geometry = SolidGeometry(g.recipe, dict(g.params), g.mesh_size, g.order, path)
        budget = MeshBudget(g.time_limit, None if g.memory_limit is None
                            else g.memory_limit * 2**30)
    elif g.type == "mesh":
        path = (base_dir / g.path).resolve()
        matrices = None
        if g.matrices is not None:
            mx = g.matrices
            matrices = MatrixFiles(mx.format, (base_dir / mx.stiffness).resolve(),
                                   (base_dir / mx.mass).resolve(), path,
                                   None if mx.dofs is None else (base_dir / mx.dofs).resolve(),
                                   mx.mass_unit)
        geometry = MeshFileGeometry(path, g.units, g.expected_mass, matrices)
        files = tuple(p for p in geometry.files() if p.is_file())
        if modes_file is not None and modes_file.is_file():
            files += (modes_file,)
    else:
        geometry = BeamGeometry(np.asarray(g.points, float), g.element_size,
                                tuple(g.vertex_names))
    mat = Material(spec.material.E, spec.material.nu, spec.material.rho)
    G = spec.material.E / (2.0 * (1.0 + spec.material.nu))
    sections = tuple(
        BeamSection(s.A, s.Iy, s.Iz, s.J, spec.material.E, G, spec.material.rho, s.y_axis)
        for s in _sections_per_member(spec))
    request = LinkRequest(
        name=spec.name, geometry=geometry, material=mat, sections=sections,
        materials=_materials(spec, geometry),
        interfaces=tuple(_interface(i, spec.name) for i in spec.interfaces),
        reference=spec.reference,
        markers=tuple(MarkerRequest(m.name, np.asarray(m.position, float),
                                    frame_axes(m.z_axis or [0, 0, 1], m.x_axis), m.radius)
                      for m in spec.markers),
        point_masses=tuple(PointMass(p.name, np.asarray(p.position, float), p.mass,
                                     None if p.inertia is None else np.asarray(p.inertia))
                           for p in spec.point_masses),
        n_modes=spec.modes.count, f_max=spec.modes.f_max,
        craig_bampton=spec.modes.craig_bampton,
        geometric_stiffening=spec.modes.geometric_stiffening, chord=spec.modes.chord,
        modes_file=modes_file,
        mesh_budget=budget,
    )
    return request, files


def _materials(spec: LinkSpec, geometry) -> tuple:
    """(element set, Material) of a link of several materials: the spec's, or those its
    mesh file's solid sections give (``materials: file``)."""
    if spec.materials != "file":
        return tuple((name, Material(m.E, m.nu, m.rho)) for name, m in spec.materials.items())
    from pipeline.meshing.file_materials import read_file_materials
    from pipeline.meshing.imported import MASS_UNITS

    if not geometry.path.is_file():
        return ()  # the mesh reader says so, at the geometry's line
    try:
        found = read_file_materials(geometry.path, geometry.format, geometry.scale,
                                    MASS_UNITS[spec.geometry.mass_unit or "kg"])
    except ConfigError as exc:  # named at the spec's materials
        raise ConfigError(f"link {spec.name!r}: materials: {exc}") from None
    return tuple((name, Material(*values)) for name, values in sorted(found.items()))


def _sections_per_member(spec: LinkSpec) -> list:
    if spec.geometry.type != "beam":
        return []
    n = len(spec.geometry.points) - 1
    out = [None] * n
    for k, s in enumerate(spec.sections):
        for i in (range(n) if s.members is None else s.members):
            if not 0 <= i < n:
                raise ConfigError(f"link {spec.name!r}: sections[{k}].members: member {i} "
                                  f"out of range 0..{n - 1}")
            out[i] = s
    missing = [i for i, s in enumerate(out) if s is None]
    if missing:
        raise ConfigError(f"link {spec.name!r}: sections: members {missing} have no section")
    return out


#: bumped whenever the reduction's numbers change for the same spec (2: repeated
#: frequencies completed and aligned with the body axes; 3: stress modes; 4: frame-force
#: geometric stiffness; 5: reference conditions in the meta, chord references; 6: the
#: acceleration cases' geometric stiffness; 7: the twelve inertia cases; 8: the frames'
#: static compliance on the full model; 9: its response to its own weight), so cached
#: artifacts are rebuilt
REDUCTION_REVISION = 9


def input_hash(spec: LinkSpec, files: tuple[Path, ...]) -> str:
    """Hash of everything that determines the artifact: spec (less the meshing budget),
    files, code versions."""
    data = spec.model_dump(mode="json")
    if not data["materials"]:  # the hashes of links of one material stay what they were
        del data["materials"]
    for key in BUDGET_FIELDS:
        data["geometry"].pop(key, None)
    return content_hash({"spec": data, "format": FORMAT_VERSION,
                         "reduction": REDUCTION_REVISION, "versions": versions()}, files)


def versions() -> dict[str, str]:
    """Versions of the pipeline and of the libraries that shape its numbers."""
    out = {"pipeline": __version__}
    for dist in _VERSIONED:
        try:
            out[dist] = importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            out[dist] = "absent"
    return out


def reduce_spec(spec: LinkSpec, base_dir: Path, out_dir: Path, rebuild: bool = False):
    """Build (or reuse) the artifact of ``spec`` in ``out_dir/<name>.npz``.

    Returns
    -------
    (ReducedLink, status) with status "hit", "miss", "corrupt" or "rebuilt".
    """
    link, status, _ = _reduce_to(spec, base_dir,
                                 lambda digest: Path(out_dir) / f"{spec.name}.npz", rebuild)
    return link, status


def reduce_cached(spec: LinkSpec, base_dir: Path, cache_dir: Path, rebuild: bool = False,
                  spec_file: Path | None = None):
    """Build (or reuse) the artifact of ``spec`` in the shared link cache ``cache_dir``
    (``<cache_dir>/<name>-<hash>/<name>.npz``, :mod:`pipeline.invariants.cache`), as every
    command does; ``spec_file`` is recorded for ``pipeline cache``.

    Returns
    -------
    (ReducedLink, status, path of the artifact).
    """
    from pipeline.invariants.cache import artifact_path

    extra = {"spec_file": str(Path(spec_file).resolve())} if spec_file is not None else {}
    return _reduce_to(spec, base_dir, lambda digest: artifact_path(cache_dir, spec.name, digest),
                      rebuild, extra)


def _reduce_to(spec: LinkSpec, base_dir: Path, path_of, rebuild: bool, extra=None):
    """(link, status, artifact path) of ``spec``, its artifact at ``path_of(input hash)``;
    ``extra``: provenance added to its meta."""
    from pipeline.core.progress import StageTimes
    from pipeline.invariants.cache import cached_reduced_link
    from pipeline.invariants.reduce import reduce_link

    request, files = link_request(spec, Path(base_dir))
    digest = input_hash(spec, files)
    meta = {"input_hash": digest, "versions": versions(),
            "settings": spec.model_dump(mode="json"), **(extra or {})}
    path = path_of(digest)
    if rebuild and path.exists():
        path.unlink()

    def build():
        return reduce_link(request, StageTimes(), meta)

    link, status = cached_reduced_link(path, digest, build)
    return link, ("rebuilt" if rebuild else status), path
