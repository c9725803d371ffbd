"""Isotropic linear-elastic materials of a solid link.

A :class:`Material` is a plain description (SI units); :func:`check_material`
validates one at the boundary and names the link in its message. A link of several
materials (a steel boom with a cast-iron eye, a welded part of two grades) assigns
them to its cells by element set (:func:`assign_materials`, :class:`CellMaterials`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.core.validate import check_in_open_interval, check_positive


@dataclass(frozen=True)
class Material:
    """Isotropic, homogeneous, linear-elastic material.

    Parameters
    ----------
    E : float
        Young's modulus, Pa.
    nu : float
        Poisson's ratio, in (-1, 0.5).
    rho : float
        Density, kg/m^3.

    Examples
    --------
    >>> steel = Material(E=210e9, nu=0.3, rho=7850.0)
    >>> round(steel.shear_modulus / 1e9, 3)
    80.769
    """

    E: float
    nu: float
    rho: float

    @property
    def shear_modulus(self) -> float:
        """G = E / (2 (1 + nu)), Pa."""
        return self.E / (2.0 * (1.0 + self.nu))

    @property
    def lame(self) -> tuple[float, float]:
        """Lame parameters (lambda, mu), Pa; see :func:`lame_parameters`."""
        return lame_parameters(self.E, self.nu)


def lame_parameters(E: float, nu: float) -> tuple[float, float]:
    """Lame parameters of an isotropic material.

    Parameters
    ----------
    E : float
        Young's modulus, Pa.
    nu : float
        Poisson's ratio.

    Returns
    -------
    lam, mu : float
        lambda = E nu / ((1 + nu)(1 - 2 nu)) and mu = E / (2 (1 + nu)), Pa.

    Examples
    --------
    >>> lame_parameters(1.0, 0.25)
    (0.4, 0.4)
    """
    lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    mu = E / (2.0 * (1.0 + nu))
    return lam, mu


def check_material(material: Material, where: str) -> Material:
    """Validate ``material``; return it as a new :class:`Material` of floats.

    Parameters
    ----------
    material : Material
        The material to check.
    where : str
        Owner named in messages, e.g. ``"link 'arm'"``.

    Returns
    -------
    Material

    Raises
    ------
    ConfigError
        If E or rho is not a finite value > 0 or nu is not in (-1, 0.5).

    Examples
    --------
    >>> check_material(Material(70e9, 0.5, 2700.0), "link 'arm'")
    Traceback (most recent call last):
    ...
    pipeline.core.errors.ConfigError: link 'arm': material.nu: expected a value in (-1, 0.5), got 0.5
    """
    E = check_positive(material.E, f"{where}: material.E")
    nu = check_in_open_interval(material.nu, -1, 0.5, f"{where}: material.nu")
    rho = check_positive(material.rho, f"{where}: material.rho")
    return Material(E=E, nu=nu, rho=rho)


@dataclass(frozen=True)
class CellMaterials:
    """The materials of a solid's cells: ``materials[index[e]]`` is cell e's; ``names[k]``
    says where ``materials[k]`` came from (``material`` for the link's own, else the
    element set's name).

    index : (n_cells,) int; materials : tuple of :class:`Material`; names : tuple of str.
    """

    index: np.ndarray
    materials: tuple
    names: tuple

    @property
    def lame(self) -> tuple[np.ndarray, np.ndarray]:
        """Each cell's Lame parameters (lambda (n_cells,), mu (n_cells,)), Pa."""
        table = np.array([m.lame for m in self.materials]).reshape(-1, 2)
        return table[self.index, 0], table[self.index, 1]

    @property
    def density(self) -> np.ndarray:
        """Each cell's density (n_cells,), kg/m^3."""
        return np.array([m.rho for m in self.materials])[self.index]

    @property
    def uniform(self) -> bool:
        """One material for every cell."""
        return len(self.materials) == 1


def _element_set(name: str, cell_groups: Mapping[str, np.ndarray], where: str):
    """The cells (int array) of element set ``name``, or None if the mesh has none of that
    name. Matched exactly, else regardless of case (Abaqus and CalculiX names are: a
    ``*SOLID SECTION, ELSET=steel`` means the ``*ELSET, ELSET=STEEL``); two sets that differ
    only in case are not guessed between."""
    if name in cell_groups:
        return np.asarray(cell_groups[name], dtype=np.int64)
    alike = sorted(n for n in cell_groups if n.casefold() == name.casefold())
    if len(alike) > 1:
        raise ConfigError(f"{where}: materials.{name}: the mesh has element sets {alike}, "
                          "which differ only in case: name one exactly")
    return np.asarray(cell_groups[alike[0]], dtype=np.int64) if alike else None


def assign_materials(material: Material, materials: Mapping[str, Material],
                     cell_groups: Mapping[str, np.ndarray], n_cells: int,
                     where: str) -> CellMaterials:
    """The material of each of ``n_cells`` cells: ``materials`` by element-set name (the
    mesh's ``cell_groups``: cell indices per set), ``material`` for the cells in none.

    Raises
    ------
    ConfigError
        A bad material; a set the mesh does not have; two sets that give one cell
        different materials.

    Examples
    --------
    >>> steel, alu = Material(210e9, 0.3, 7850.0), Material(70e9, 0.33, 2700.0)
    >>> cm = assign_materials(steel, {"ARM": alu}, {"ARM": np.array([1, 2])}, 4, "link 'a'")
    >>> cm.index.tolist(), cm.names, cm.density.tolist()
    ([0, 1, 1, 0], ('material', 'ARM'), [7850.0, 2700.0, 2700.0, 7850.0])
    """
    own = [check_material(material, where)]
    index = np.zeros(n_cells, dtype=np.int64)
    given_by: dict[int, str] = {}
    for k, (name, mat) in enumerate(materials.items(), start=1):
        own.append(check_material(mat, f"{where}: materials.{name}"))
        cells = _element_set(name, cell_groups, where)
        if cells is None:
            known = sorted(cell_groups)
            raise ConfigError(
                f"{where}: materials.{name}: the mesh has no element set {name!r} "
                + (f"(its element sets: {known})" if known else
                   "(it has no element sets: materials by element set need a mesh file that "
                   "names them: Abaqus ELSET, gmsh physical volumes, Nastran property ids "
                   "PID<n>)"))
        if cells.size and (cells.min() < 0 or cells.max() >= n_cells):
            raise ConfigError(f"{where}: materials.{name}: element set {name!r} names cells "
                              f"outside the solid's {n_cells}")
        taken = cells[index[cells] != 0]
        clash = taken[[own[index[c]] != own[k] for c in taken]]
        if clash.size:
            first = int(clash[0])
            raise ConfigError(
                f"{where}: materials.{name}: element sets {given_by[int(index[first])]!r} and "
                f"{name!r} share {clash.size} cell(s) (first cell {first}) and give them "
                "different materials: give each cell one material")
        index[cells] = k
        given_by[k] = name
    return CellMaterials(index, tuple(own), ("material", *materials))
