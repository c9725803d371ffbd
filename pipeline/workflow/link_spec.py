"""Link specification (YAML) for ``pipeline reduce`` and the workflow ``links:``.

A link spec says how to build one reduced link: geometry and mesh, material
or beam sections, named interfaces (joint frames), markers, point masses and
the modes to keep. Fields are SI units. Unknown keys are rejected.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from pipeline.meshing.budget import MESH_SECONDS
from pipeline.workflow.yaml_io import _fmt, config_error, load_yaml

Vec3 = Annotated[list[float], Field(min_length=3, max_length=3)]
Mat3 = Annotated[list[Vec3], Field(min_length=3, max_length=3)]
#: the largest coordinate a position may have, m (a machine is not 1000 km long; 1e308 m
#: would overflow the 4x4 products)
MAX_COORDINATE = 1.0e6
#: a position, m: three numbers within +-MAX_COORDINATE
Pos3 = Annotated[list[Annotated[float, Field(ge=-MAX_COORDINATE, le=MAX_COORDINATE)]],
                 Field(min_length=3, max_length=3)]


class Strict(BaseModel):
    # strict: no booleans or strings for numbers; finite numbers only
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False)


class MaterialSpec(Strict):
    E: float = Field(gt=0, description="Young's modulus, Pa")
    nu: float = Field(gt=-1, lt=0.5, description="Poisson's ratio, in (-1, 0.5)")
    rho: float = Field(gt=0, description="density, kg/m^3")


class SectionSpec(Strict):
    A: float = Field(gt=0, description="area, m^2")
    Iy: float = Field(gt=0, description="second moment about local y, m^4")
    Iz: float = Field(gt=0, description="second moment about local z, m^4")
    J: float = Field(gt=0, description="torsion constant, m^4")
    y_axis: Vec3 | None = Field(None, description="direction of the local y axis (link frame)")
    members: list[int] | None = Field(
        None, description="polyline members (0-based) with this section; default all")


#: geometry fields that bound the work, not the result: left out of a link's input hash
BUDGET_FIELDS = ("time_limit", "memory_limit")


class SolidGeometrySpec(Strict):
    type: Literal["solid"]
    recipe: str = Field(description="bar | plate_with_bores | bent_plate | box_section | geo | step")
    params: dict[str, Any] = Field(default_factory=dict, description="recipe parameters, SI")
    path: str | None = Field(None, description=".geo or STEP file, relative to the spec file")
    mesh_size: float = Field(gt=0, description="target element size, m")
    order: int = Field(2, ge=1, le=2, description="geometric order of the tetrahedra, 1 or 2")
    time_limit: float = Field(MESH_SECONDS, gt=0, allow_inf_nan=False,
                              description="wall time meshing may take, s (it runs in its own "
                                          "process, stopped at this limit)")
    memory_limit: float | None = Field(None, gt=0, allow_inf_nan=False,
                                       description="memory meshing may take and its "
                                                   "reduction will need, GB (default: what "
                                                   "the machine has available)")


class BeamGeometrySpec(Strict):
    type: Literal["beam"]
    points: list[Pos3] = Field(min_length=2, description="polyline vertices, m")
    vertex_names: list[str] = Field(default_factory=list, description="names of the vertices")
    element_size: float = Field(gt=0, description="target beam element length, m")


class MatricesSpec(Strict):
    format: Literal["calculix", "abaqus"] = Field(
        description="calculix: .sti/.mas/.dof of *FREQUENCY, SOLVER=MATRIXSTORAGE; abaqus: "
                    "coordinate-format .mtx of *MATRIX GENERATE")
    stiffness: str = Field(description="stiffness matrix file, relative to the spec file")
    mass: str = Field(description="mass matrix file, relative to the spec file")
    dofs: str | None = Field(None, description="CalculiX .dof file (node.direction per row)")
    mass_unit: Literal["kg", "t", "g"] = Field(
        "kg", description="the FE model's mass unit (t with mm: N/mm stiffness)")


class MeshGeometrySpec(Strict):
    type: Literal["mesh"]
    path: str = Field(description="mesh file of another FE tool, relative to the spec file: "
                                  "Abaqus .inp, Nastran .bdf/.nas, gmsh .msh, .vtu, .xdmf")
    units: Literal["m", "mm", "cm", "in", "ft"] = Field(
        description="length unit of the file's coordinates (scaled to m)")
    expected_mass: float | None = Field(
        None, gt=0, description="the link's mass as the FE tool reports it, kg: checked "
                                "within 5 % (catches a wrong unit or density)")
    mass_unit: Literal["kg", "t", "g"] | None = Field(
        None, description="the mass unit of the file's consistent units, for materials read "
                          "from it (t with mm: N, MPa, t/mm^3; default kg with m)")
    matrices: MatricesSpec | None = Field(
        None, description="the FE tool's own free-free K and M of this mesh (path then is "
                          "its .inp input), used instead of assembling them here")

    @model_validator(mode="after")
    def _matrices_need_inp(self):
        if self.matrices is not None and not self.path.lower().endswith(".inp"):
            raise ValueError("with matrices, path is the FE tool's .inp input (its *NODE "
                             "lines number the matrices' rows)")
        if self.matrices is not None and self.matrices.format == "calculix" and \
                self.matrices.dofs is None:
            raise ValueError("CalculiX matrices need matrices.dofs (the .dof file)")
        return self


class GroupSelector(Strict):
    type: Literal["group"]
    name: str


class CylinderSelector(Strict):
    type: Literal["cylinder"]
    point: Pos3 = Field(description="a point on the axis, m")
    axis: Vec3
    radius: float = Field(gt=0, description="m")
    tol: float | None = Field(None, gt=0, description="radial tolerance, m")


class PlaneSelector(Strict):
    type: Literal["plane"]
    point: Pos3
    normal: Vec3
    tol: float | None = Field(None, gt=0, description="m")


class NearestSelector(Strict):
    type: Literal["nearest"]
    point: Pos3


class BoxSelector(Strict):
    type: Literal["box"]
    lo: Pos3
    hi: Pos3


Selector = Annotated[
    GroupSelector | CylinderSelector | PlaneSelector | NearestSelector | BoxSelector,
    Field(discriminator="type"),
]


class InterfaceSpec(Strict):
    name: str
    selector: Selector
    origin: Pos3 | None = Field(
        None, description="reference point, m (default: the selector's point)")
    z_axis: Vec3 | None = Field(
        None, description="joint axis (default: cylinder axis, plane normal or z)")
    x_axis: Vec3 | None = Field(None, description="frame x axis (default: chosen normal to z)")
    kind: Literal["rbe2", "rbe3"] = Field("rbe2", description="rigid tie or averaging")


class MarkerSpec(Strict):
    name: str
    position: Pos3 = Field(description="m")
    z_axis: Vec3 | None = None
    x_axis: Vec3 | None = None
    radius: float | None = Field(
        None, gt=0, description="fit the marker motion over nodes within this radius, m")


class PointMassSpec(Strict):
    name: str
    position: Pos3 = Field(description="m")
    mass: float = Field(gt=0, description="kg")
    inertia: Mat3 | None = Field(None, description="about its own centre, kg m^2")


class ModesSpec(Strict):
    count: int | None = Field(None, ge=0, description="number of fixed-interface modes")
    f_max: float | None = Field(None, gt=0, description="keep modes up to this frequency, Hz")
    craig_bampton: bool = Field(False, description="add constraint modes of the other interfaces")
    chord: str | None = Field(
        None, description="chord reference: instead of clamping the reference interface, hold "
                          "it in translation and about the line to this interface, which moves "
                          "along that line only (a link pinned at both ends)")
    file: str | None = Field(
        None, description="clamped modes computed by another FE code, relative to the spec "
                          "file: CalculiX .frd of a *FREQUENCY step clamped at the "
                          "reference's nodes (*NODE FILE U; *EL FILE S for stresses), on the "
                          "mesh of geometry.path (.inp); used instead of solving for them")
    geometric_stiffening: bool = Field(
        False, description="compute the geometric stiffness of the modes under forces at their "
                           "frames, uniform accelerations and their own spin (beams, P2 "
                           "solids), used when a workflow sets the link's geometric_stiffening")

    @model_validator(mode="after")
    def _one_rule(self):
        if self.count is None and self.f_max is None:
            raise ValueError("give modes.count or modes.f_max")
        if self.count == 0 and not self.craig_bampton:
            raise ValueError("count 0 needs craig_bampton: true (the constraint modes alone); "
                             "a link without modes is a rigid link in the workflow")
        if self.chord is not None and self.craig_bampton:
            raise ValueError("chord and craig_bampton exclude each other (the chord reference "
                             "already holds the far interface)")
        if self.file is not None and (self.craig_bampton or self.chord is not None):
            raise ValueError("modes from a file are clamped at the reference: craig_bampton "
                             "and chord do not apply")
        return self


class LinkSpec(Strict):
    name: str = Field(pattern=r"^[A-Za-z_][A-Za-z0-9_\-]*$")
    geometry: Annotated[SolidGeometrySpec | BeamGeometrySpec | MeshGeometrySpec,
                        Field(discriminator="type")]
    material: MaterialSpec
    materials: dict[str, MaterialSpec] | Literal["file"] = Field(
        default_factory=dict,
        description="materials by element set of an imported mesh (Abaqus ELSET, gmsh "
                    "physical volume, Nastran property id as PID<n>), or 'file': the "
                    "materials the file's solid sections give (*SOLID SECTION, PSOLID), in "
                    "geometry.units and geometry.mass_unit; cells in none of them have "
                    "material")
    sections: list[SectionSpec] = Field(default_factory=list, validate_default=True,
                                       description="beam sections, one per member")
    interfaces: list[InterfaceSpec] = Field(min_length=1)
    reference: str = Field(description="interface that is the body frame (modes clamped there)")
    markers: list[MarkerSpec] = Field(default_factory=list)
    point_masses: list[PointMassSpec] = Field(default_factory=list)
    modes: ModesSpec

    @field_validator("reference")
    @classmethod
    def _reference_is_interface(cls, value: str, info: ValidationInfo) -> str:
        names = [i.name for i in info.data.get("interfaces", [])]
        if names and value not in names:
            raise ValueError(f"expected one of the interfaces {names}, got {value!r}")
        return value

    @field_validator("modes")
    @classmethod
    def _modes_file_needs_its_input(cls, value: ModesSpec, info: ValidationInfo) -> ModesSpec:
        geometry = info.data.get("geometry")
        if value.file is not None and geometry is not None and (
                geometry.type != "mesh" or not geometry.path.lower().endswith(".inp")):
            raise ValueError("file: modes from another FE code need its input as the mesh "
                             "(geometry type mesh with the FE code's .inp, whose *NODE "
                             "numbers the results use)")
        return value

    @field_validator("modes")
    @classmethod
    def _chord_is_far_interface(cls, value: ModesSpec, info: ValidationInfo) -> ModesSpec:
        others = [i.name for i in info.data.get("interfaces", [])
                  if i.name != info.data.get("reference")]
        if value.chord is not None and value.chord not in others:
            raise ValueError(f"chord: expected one of the interfaces other than the reference "
                             f"{others}, got {value.chord!r}")
        return value

    @field_validator("materials")
    @classmethod
    def _materials_need_element_sets(cls, value: dict, info: ValidationInfo) -> dict:
        geometry = info.data.get("geometry")
        if value and geometry is not None and geometry.type != "mesh":
            raise ValueError("materials by element set need a mesh file that names its sets "
                             "(geometry type mesh); this link's geometry is a "
                             f"{geometry.type}")
        if value and geometry is not None and geometry.matrices is not None:
            raise ValueError("a link imported as matrices has its materials in them; "
                             "leave materials out")
        if value == "file" and geometry is not None:
            if Path(geometry.path).suffix.lower() not in (".inp", ".bdf", ".nas", ".fem"):
                raise ValueError("materials from the file are read from Abaqus/CalculiX .inp "
                                 "and Nastran .bdf/.nas/.fem files; give them by element set "
                                 "for this one")
            if geometry.mass_unit is None and geometry.units != "m":
                raise ValueError(f"materials from a file in {geometry.units} need "
                                 "geometry.mass_unit, the mass unit of the file's consistent "
                                 "set (t with mm, N and MPa)")
        return value

    @field_validator("sections")
    @classmethod
    def _beam_needs_sections(cls, value: list, info: ValidationInfo) -> list:
        geometry = info.data.get("geometry")
        if geometry is not None and geometry.type == "beam" and not value:
            raise ValueError("a beam link needs at least one section")
        return value

    @field_validator("interfaces")
    @classmethod
    def _unique_interfaces(cls, value: list) -> list:
        _check_unique([i.name for i in value], "")
        return value

    @field_validator("markers")
    @classmethod
    def _unique_markers(cls, value: list, info: ValidationInfo) -> list:
        taken = [i.name for i in info.data.get("interfaces", [])]
        _check_unique(taken + [m.name for m in value], " among interfaces and markers",
                      start=len(taken))
        return value


def _check_unique(names: list[str], among: str, start: int = 0) -> None:
    """ValueError naming the frame names of ``names[start:]`` met twice in ``names``."""
    dup = sorted({n for n in names[start:] if names.count(n) > 1})
    if dup:
        raise ValueError(f"duplicate frame name(s) {dup}{among}")


def load_link_spec(path: str | Path) -> LinkSpec:
    """Read and validate a link spec YAML; ConfigError names file, line and field."""
    return load_link_spec_lines(path)[0]


def load_link_spec_lines(path: str | Path) -> tuple[LinkSpec, dict]:
    """(LinkSpec, YAML path -> line) of a link spec file (see :func:`locate`)."""
    data, lines = load_yaml(path)
    try:
        return LinkSpec.model_validate(data), lines
    except ValidationError as exc:
        raise config_error(exc, path, data, lines) from None


def locate(message: str, spec: LinkSpec, path: str | Path, lines: dict,
           default: tuple = ()) -> str:
    """``file:line: yaml.path: message`` for an error met while meshing or reducing
    ``spec``: the interface, marker or point mass the message names, else the spec path it
    writes (``sections[0].members``, ``modes.chord``), else ``default`` (e.g.
    ("geometry",) for a meshing error)."""
    key: tuple = default
    item = re.search(r"(interface|marker|point mass) '([^']+)'", message)
    written = re.search(r"\b(geometry|materials|material|sections|interfaces|markers|"
                        r"point_masses|modes)"
                        r"((?:\[\d+\]|\.\w+)+|(?=:))", message)  # a path, or a key and ':'
    setting = re.search(r"\b(craig_bampton|chord)\b", message)
    param = re.search(r"\bparams((?:\[\d+\]|\.\w+)+)", message)  # a recipe's own check
    if item:
        field = {"interface": "interfaces", "marker": "markers",
                 "point mass": "point_masses"}[item.group(1)]
        names = [x.name for x in getattr(spec, field)]
        if item.group(2) in names:
            key = (field, names.index(item.group(2)))
    elif written:
        parts = re.findall(r"\[(\d+)\]|\.(\w+)", written.group(2))
        key = (written.group(1), *(int(i) if i else name for i, name in parts))
    elif param:
        parts = re.findall(r"\[(\d+)\]|\.(\w+)", param.group(1))
        key = ("geometry", "params", *(int(i) if i else name for i, name in parts))
    elif setting:  # a reference condition the interfaces do not allow
        key = ("modes", setting.group(1))
    while key and key not in lines:
        key = key[:-1]
    return f"{path}:{lines.get(key, 1)}: {_fmt(key)}: {message}"
