"""The public Python API: every noun a user needs, from link geometry to pictures, under
stable names (``from pipeline import api``; walked through in ``docs/python_api.md``).

Units are SI throughout (m, kg, s, N, rad); shapes are in each function's docstring.

Links
    :func:`reduce_link` (a link spec YAML -> :class:`ReducedLink`: mesh, FE, modes,
    invariants, stress modes, cached by content), :func:`load_link_spec`,
    :func:`kept_modes` (the mode filter: a count, indices, a rule, or only the modes
    moving in a plane), :func:`effective_mass_fractions` (each mode's share of the link's
    mass and inertia at a frame).
Mechanism (kinematics)
    :func:`rigid_link`, :func:`link_from_reduced`, :class:`Joint` (types in :data:`JOINTS`),
    :func:`build_mechanism`, :func:`initial_positions`, :func:`dof_report`, :func:`sweep`;
    drivers :class:`Constant`, :class:`Ramp`, :class:`SmoothStep`, :class:`Harmonic`,
    :class:`Table`.
Dynamics
    :class:`System`, :class:`BodyMass`, :func:`body_from_reduced`; force elements
    :class:`SpringDamper`, :class:`JointSpringDamper`, :class:`JointForce`,
    :class:`PointForce`,
    :class:`Torque`, :class:`ForceCylinder`, :class:`HydraulicCylinder` (chamber pressures
    as states, a 4/3 valve) (geometric stiffening is in the links:
    ``body_from_reduced(..., second_order=True)``, ``link_from_reduced(...,
    second_order=True)``); analyses :func:`static_equilibrium`,
    :func:`kinetostatics` (with joint reactions), :func:`simulate` (checked transient:
    ``result.verdict``), :func:`vibration_modes`, :func:`marker_motion`; stepping from
    outside (a controller, a co-simulation): :class:`Simulator` (``step(dt, inputs)``,
    ``state``/``set_state``, ``result()``); FMUs and digital controllers beside it:
    :class:`FMU`, :class:`SampledPID`, :func:`cosimulate`.
Results
    :func:`marker_positions` (positions and deflections in ground or any link's axes),
    :func:`energies`, :func:`series` (any named history, stresses included),
    :func:`von_mises`, :func:`principal_stresses`.
Pictures
    :func:`machine_shapes` / :func:`shape_from_reduced`, :func:`render_machine`,
    :func:`render_positions`, :func:`animate_machine`, :func:`render_modes`,
    :func:`write_vtk_series`, :func:`plot_panels` (a PNG) or :func:`panels_figure` (a
    Figure, for a notebook); :func:`machine_plotter` (a pyvista Plotter) and
    :func:`machine_blocks` (a MultiBlock of the links by name), for a notebook; a study's
    charts as Figures: :func:`convergence_figure`, :func:`outputs_figure`.
Workflows and studies
    :func:`load_workflow`, :func:`build_machine`, :func:`run_workflow`, :func:`run_study`
    (mode-truncation and design studies on Dask, ``docs/studies.md``).

Importing this module is cheap (no numpy, scipy or numba yet): each name is imported from
its home module on first use (PEP 562), and gmsh, scikit-fem and pyvista load only when a
function that needs them runs. ``tests/bench/test_bench_import.py`` measures it.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import TYPE_CHECKING

#: public name -> the module that defines it
_HOMES = {
    "BodyMass": "pipeline.dynamics",
    "System": "pipeline.dynamics",
    "body_from_reduced": "pipeline.dynamics",
    "energies": "pipeline.dynamics",
    "kinetostatics": "pipeline.dynamics",
    "link_from_reduced": "pipeline.dynamics",
    "marker_motion": "pipeline.dynamics",
    "static_equilibrium": "pipeline.dynamics",
    "vibration_modes": "pipeline.dynamics",
    "HydraulicCylinder": "pipeline.dynamics.forces.hydraulics",
    "ForceCylinder": "pipeline.dynamics.forces.loads",
    "JointForce": "pipeline.dynamics.forces.loads",
    "PointForce": "pipeline.dynamics.forces.loads",
    "Torque": "pipeline.dynamics.forces.loads",
    "JointSpringDamper": "pipeline.dynamics.forces.springs",
    "SpringDamper": "pipeline.dynamics.forces.springs",
    "principal_stresses": "pipeline.fem.stress",
    "von_mises": "pipeline.fem.stress",
    "effective_mass_fractions": "pipeline.invariants.participation",
    "ReducedLink": "pipeline.invariants.reduced_link",
    "JOINTS": "pipeline.kinematics",
    "Joint": "pipeline.kinematics",
    "build_mechanism": "pipeline.kinematics",
    "dof_report": "pipeline.kinematics",
    "rigid_link": "pipeline.kinematics",
    "sweep": "pipeline.kinematics",
    "Constant": "pipeline.kinematics.driver_base",
    "Table": "pipeline.kinematics.driver_table",
    "Harmonic": "pipeline.kinematics.drivers",
    "Ramp": "pipeline.kinematics.drivers",
    "SmoothStep": "pipeline.kinematics.drivers",
    "initial_positions": "pipeline.kinematics.initial",
    "Curve": "pipeline.post.plots",
    "Panel": "pipeline.post.plots",
    "plot_panels": "pipeline.post.plots",
    "panels_figure": "pipeline.post.plots",
    "convergence_figure": "pipeline.post.study_plot",
    "outputs_figure": "pipeline.post.study_plot",
    "render_modes": "pipeline.post.render",
    "Picture": "pipeline.post.scene",
    "Style": "pipeline.post.scene",
    "animate_machine": "pipeline.post.scene",
    "render_machine": "pipeline.post.scene",
    "render_positions": "pipeline.post.scene",
    "machine_plotter": "pipeline.post.scene",
    "machine_blocks": "pipeline.post.vtk_series",
    "LinkShape": "pipeline.post.shapes",
    "shape_from_reduced": "pipeline.post.shapes",
    "write_vtk_series": "pipeline.post.vtk_series",
    "Limits": "pipeline.solver",
    "SimulationResult": "pipeline.solver",
    "simulate": "pipeline.solver",
    "FMU": "pipeline.solver.cosim",
    "SampledPID": "pipeline.solver.cosim",
    "cosimulate": "pipeline.solver.cosim",
    "Simulator": "pipeline.solver.simulator",
    "SimulatorState": "pipeline.solver.simulator",
    "build_machine": "pipeline.workflow",
    "load_workflow": "pipeline.workflow",
    "run_workflow": "pipeline.workflow",
    "kept_modes": "pipeline.workflow.build",
    "load_link_spec": "pipeline.workflow.link_spec",
    "machine_shapes": "pipeline.workflow.outputs",
    "marker_positions": "pipeline.workflow.series",
    "series": "pipeline.workflow.series",
}

if TYPE_CHECKING:  # what the names are, for readers and type checkers
    from pipeline.dynamics import (
        BodyMass,
        System,
        body_from_reduced,
        energies,
        kinetostatics,
        link_from_reduced,
        marker_motion,
        static_equilibrium,
        vibration_modes,
    )
    from pipeline.dynamics.forces.hydraulics import HydraulicCylinder
    from pipeline.dynamics.forces.loads import (
        ForceCylinder,
        JointForce,
        PointForce,
        Torque,
    )
    from pipeline.dynamics.forces.springs import JointSpringDamper, SpringDamper
    from pipeline.fem.stress import principal_stresses, von_mises
    from pipeline.invariants.participation import effective_mass_fractions
    from pipeline.invariants.reduced_link import ReducedLink
    from pipeline.kinematics import (
        JOINTS,
        Joint,
        build_mechanism,
        dof_report,
        rigid_link,
        sweep,
    )
    from pipeline.kinematics.driver_base import Constant
    from pipeline.kinematics.driver_table import Table
    from pipeline.kinematics.drivers import Harmonic, Ramp, SmoothStep
    from pipeline.kinematics.initial import initial_positions
    from pipeline.post.plots import Curve, Panel, panels_figure, plot_panels
    from pipeline.post.render import render_modes
    from pipeline.post.scene import (
        Picture,
        Style,
        animate_machine,
        machine_plotter,
        render_machine,
        render_positions,
    )
    from pipeline.post.shapes import LinkShape, shape_from_reduced
    from pipeline.post.study_plot import convergence_figure, outputs_figure
    from pipeline.post.vtk_series import machine_blocks, write_vtk_series
    from pipeline.solver import Limits, SimulationResult, simulate
    from pipeline.solver.cosim import FMU, SampledPID, cosimulate
    from pipeline.solver.simulator import Simulator, SimulatorState
    from pipeline.workflow import build_machine, load_workflow, run_workflow
    from pipeline.workflow.build import kept_modes
    from pipeline.workflow.link_spec import load_link_spec
    from pipeline.workflow.outputs import machine_shapes
    from pipeline.workflow.series import marker_positions, series


def __getattr__(name: str):
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'pipeline.api' has no attribute {name!r}")
    value = getattr(importlib.import_module(home), name)
    globals()[name] = value  # found once: later lookups are plain attribute reads
    return value


def __dir__():
    return sorted(__all__)


def reduce_link(spec: str | Path, cache_dir: str | Path | None = None,
                rebuild: bool = False) -> ReducedLink:
    """The reduced link of a link spec YAML (``docs/link_specs.md``).

    Meshes (gmsh), assembles K and M (scikit-fem), computes the modes and the mass
    invariants C, C'_a, C''_ab -- or reads them back from the link cache ``cache_dir``
    (default: the one every command shares, ``$FLEXMECH_LINKS`` or ``output/links``) when
    the spec and the files it names are unchanged (content hash). Paths in the spec are
    relative to the spec's folder.

    Raises
    ------
    ConfigError
        A bad spec: file:line: field: what was expected.
    """
    from pipeline.invariants.cache import default_links_dir
    from pipeline.workflow.link_build import reduce_cached
    from pipeline.workflow.link_spec import load_link_spec

    spec = Path(spec)
    cache = default_links_dir() if cache_dir is None else Path(cache_dir)
    link, _, _ = reduce_cached(load_link_spec(spec), spec.parent, cache, rebuild, spec)
    return link


__all__ = [
    "FMU", "JOINTS", "BodyMass", "Constant", "Curve", "ForceCylinder", "Harmonic",
    "HydraulicCylinder", "Joint", "JointForce", "JointSpringDamper", "Limits", "LinkShape",
    "Panel", "Picture", "PointForce", "Ramp", "ReducedLink", "SampledPID", "SimulationResult",
    "Simulator", "SimulatorState", "SmoothStep", "SpringDamper",
    "Style", "System", "Table", "Torque", "animate_machine", "body_from_reduced",
    "build_machine", "build_mechanism", "convergence_figure", "cosimulate", "dof_report",
    "effective_mass_fractions", "energies",
    "initial_positions", "kept_modes", "kinetostatics", "link_from_reduced", "load_link_spec",
    "load_workflow", "machine_blocks", "machine_plotter", "machine_shapes", "marker_motion",
    "marker_positions", "outputs_figure", "panels_figure",
    "plot_panels", "principal_stresses", "reduce_link", "render_machine", "render_modes", "render_positions",
    "rigid_link", "run_study", "run_workflow", "series", "shape_from_reduced", "simulate",
    "static_equilibrium", "sweep", "vibration_modes", "von_mises", "write_vtk_series",
]


def run_study(study: str | Path, **kwargs):
    """Run a study YAML (``docs/studies.md``); see :func:`pipeline.study.engine.run_study`
    for the keywords (``out_root``, ``workers``, ``scheduler``, ``cache_dir``). Needs the
    ``study`` extra (dask.distributed, pyarrow)."""
    from pipeline.study.engine import run_study as _run

    return _run(study, **kwargs)
