"""Sample links for the tests: solid bar specs (the aluminium bar written to a file; any
bar with two end interfaces as text), a straight beam spec, and a random artifact."""

import textwrap
from pathlib import Path

import numpy as np

from pipeline.invariants.body_frame import pose
from pipeline.invariants.reduced_link import FrameModes, ReducedLink

BAR = """\
name: bar
geometry:
  type: solid
  recipe: bar
  params: {{L: {L}, b: {b}, h: {h}}}
  mesh_size: {size}
  order: 2
material: {{E: 70.0e9, nu: 0.3, rho: 2700}}
interfaces:
  - name: root
    selector: {{type: group, name: end_x0}}
    origin: [0, 0, 0]
    z_axis: [1, 0, 0]
    x_axis: [0, 0, 1]
  - name: tip
    selector: {{type: group, name: end_xL}}
    origin: [{L}, 0, 0]
    z_axis: [1, 0, 0]
reference: root
markers:
  - {{name: mid, position: [{half}, 0, 0], radius: {size}}}
modes: {{count: {modes}}}
"""


def write_bar(folder: Path, L=0.2, b=0.02, h=0.01, size=0.01, modes=6, name="bar.yaml") -> Path:
    p = folder / name
    p.write_text(textwrap.dedent(BAR.format(L=L, b=b, h=h, size=size, modes=modes, half=L / 2)))
    return p


def random_link(m=3, n=20, seed=0):
    """A ReducedLink with random arrays (for storage tests)."""
    rng = np.random.default_rng(seed)
    frames = tuple(
        FrameModes(f"f{i}", pose(rng.normal(size=3), np.eye(3)), rng.normal(size=(m, 3)),
                   rng.normal(size=(m, 3)), "interface" if i < 2 else "marker")
        for i in range(3)
    )
    C = rng.normal(size=(4, 4))
    return ReducedLink(
        name="arm", kind="solid", body_pose=np.eye(4), C=C + C.T,
        Cp=rng.normal(size=(m, 4, 4)), Cpp=rng.normal(size=(m, m, 4, 4)),
        modal_stiffness=np.diag(rng.uniform(1, 2, m)), modal_mass=np.eye(m),
        frequencies_hz=np.sort(rng.uniform(1, 100, m)), mode_kinds=("normal",) * m,
        frames=frames, nodes=rng.normal(size=(n, 3)), cells=np.arange(20).reshape(2, 10),
        surface=np.arange(12).reshape(2, 6), mode_shapes=rng.normal(size=(m, n, 3)),
        meta={"input_hash": "abc", "settings": {"n_modes": m}},
    )


def beam_spec(name: str, length: float, *, A: float, Iy: float, Iz: float, J: float,
              element_size: float, E: float = 2.1e11, nu: float = 0.3, rho: float = 7850.0,
              ends=("root", "tip"), interfaces=("root",), markers=None, modes="{count: 8}",
              z_axis=None) -> str:
    """The YAML of a straight beam link along x from 0 to ``length`` (m): one section,
    ``interfaces`` (names of ``ends``) on the end nodes, the first the reference,
    ``markers`` {name: x (m)}, ``modes`` as YAML text, optional interface ``z_axis``."""
    at = dict(zip(ends, (0.0, length), strict=True))
    axis = "" if z_axis is None else f", z_axis: {list(z_axis)}"
    geometry = (f"{{type: beam, points: [[0, 0, 0], [{length!r}, 0, 0]], "
                f"vertex_names: {list(ends)}, element_size: {element_size!r}}}")
    lines = [f"name: {name}", f"geometry: {geometry}",
             f"material: {{E: {E!r}, nu: {nu!r}, rho: {rho!r}}}",
             f"sections: [{{A: {A!r}, Iy: {Iy!r}, Iz: {Iz!r}, J: {J!r}, members: [0]}}]",
             "interfaces:"]
    lines += [f"  - {{name: {n}, selector: {{type: nearest, point: [{at[n]!r}, 0, 0]}}{axis}}}"
              for n in interfaces]
    lines.append(f"reference: {interfaces[0]}")
    if markers:
        lines.append("markers:")
        lines += [f"  - {{name: {n}, position: [{x!r}, 0, 0]}}" for n, x in markers.items()]
    lines.append(f"modes: {modes}")
    return "\n".join(lines) + "\n"


def solid_bar_spec(name: str, length: float, b: float, h: float, *, mesh_size: float,
                   E: float = 2.1e11, nu: float = 0.3, rho: float = 7850.0,
                   ends=("A", "B"), modes="{count: 8}") -> str:
    """The YAML of a P2 solid bar (recipe ``bar``: x from 0 to ``length``, section b along
    y by h along z, m) with RBE2 interfaces ``ends`` on its end faces, joint axes along z,
    the first the reference; ``modes`` as YAML text."""
    lines = [f"name: {name}",
             (f"geometry: {{type: solid, recipe: bar, params: {{L: {length!r}, b: {b!r}, "
              f"h: {h!r}}}, mesh_size: {mesh_size!r}, order: 2}}"),
             f"material: {{E: {E!r}, nu: {nu!r}, rho: {rho!r}}}", "interfaces:"]
    lines += [f"  - {{name: {n}, selector: {{type: group, name: {g}}}, origin: [{x!r}, 0, 0], "
              "z_axis: [0, 0, 1]}"
              for n, g, x in zip(ends, ("end_x0", "end_xL"), (0.0, length), strict=True)]
    lines += [f"reference: {ends[0]}", f"modes: {modes}"]
    return "\n".join(lines) + "\n"


def boom_spec(length: float, pin: float, *, A: float, Iy: float, Iz: float, J: float,
              modes: str, neck_iz: float | None = None, E: float = 2.1e11,
              element_size: float = 0.05, rho: float = 7850.0) -> str:
    """The YAML of a straight beam boom along x with interfaces ``root`` (the reference, at
    0), ``pin`` and ``tip`` (at ``pin`` and ``length``, m); with ``neck_iz`` its first 5 cm
    have that second moment about z (a small, soft bore at the root)."""
    stations = [0.0] + ([0.05] if neck_iz is not None else []) + [pin, length]
    names = ["root"] + (["neck"] if neck_iz is not None else []) + ["pin", "tip"]
    n = len(stations) - 1
    main = list(range(1, n)) if neck_iz is not None else list(range(n))
    sections = [f"  - {{A: {A!r}, Iy: {Iy!r}, Iz: {Iz!r}, J: {J!r}, members: {main}}}"]
    if neck_iz is not None:
        sections.append(f"  - {{A: {A!r}, Iy: {Iy!r}, Iz: {neck_iz!r}, J: {J!r}, members: [0]}}")
    points = ", ".join(f"[{x!r}, 0, 0]" for x in stations)
    lines = ["name: boom",
             (f"geometry: {{type: beam, points: [{points}], vertex_names: {names}, "
              f"element_size: {element_size!r}}}"),
             f"material: {{E: {E!r}, nu: 0.3, rho: {rho!r}}}", "sections:", *sections,
             "interfaces:"]
    lines += [f"  - {{name: {nm}, selector: {{type: nearest, point: [{x!r}, 0, 0]}}}}"
              for nm, x in (("root", 0.0), ("pin", pin), ("tip", length))]
    lines += ["reference: root", f"modes: {modes}"]
    return "\n".join(lines) + "\n"
