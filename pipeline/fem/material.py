"""Isotropic linear-elastic material of a solid link.

A :class:`Material` is a plain description (SI units); :func:`check_material`
validates one at the boundary and names the link in its message.
"""

from __future__ import annotations

from dataclasses import dataclass

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
