"""Beam cross-section data and the local frame of a beam element.

A beam element's local frame is ``x`` along the element (from its first to its
second node), ``y`` the section's orientation vector projected normal to ``x``,
and ``z = x cross y``. Section properties refer to the centroidal principal
axes: ``Iy = int z^2 dA`` (bending in the local x-z plane, rotation about y),
``Iz = int y^2 dA`` (bending in the local x-y plane, rotation about z).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.core.validate import check_positive

# An element whose direction is within this sine of the orientation vector has
# no usable y axis (user vector) or falls back to global Y (default rule).
PARALLEL_SINE = 1e-6

_POSITIVE_FIELDS = ("A", "Iy", "Iz", "J", "E", "G", "rho")


@dataclass(frozen=True)
class BeamSection:
    """Cross-section and material of a straight beam member (SI units).

    Parameters
    ----------
    A : float
        Area, m^2.
    Iy, Iz : float
        Second moments of area about the local y and z axes, m^4
        (``Iy = int z^2 dA``, ``Iz = int y^2 dA``).
    J : float
        Saint-Venant torsion constant, m^4 (stiffness ``G J``). The polar
        rotary inertia uses ``Iy + Iz`` instead (mass per length
        ``rho (Iy + Iz)``), which differs from ``J`` for non-circular sections.
    E, G : float
        Young's and shear modulus, Pa.
    rho : float
        Density, kg/m^3.
    y_axis : (3,) sequence of float or None
        Direction of the local y axis in the link frame; only its part normal
        to the element is used. ``None`` (default): ``y = Z x e_x`` normalised
        (horizontal, so that bending in a vertical plane containing the member
        is bending about y, i.e. uses ``Iy``); for a member within
        :data:`PARALLEL_SINE` of vertical, ``y`` = global Y.

    Notes
    -----
    Per unit length the section's second-moment tensor and rotary inertia are
    ``S_sec = rho (Iz e_y e_y^T + Iy e_z e_z^T)`` and
    ``tr(S_sec) 1 - S_sec = rho ((Iy + Iz) e_x e_x^T + Iy e_y e_y^T + Iz e_z e_z^T)``.

    Examples
    --------
    >>> s = BeamSection(A=1e-4, Iy=2e-9, Iz=1e-9, J=2.5e-9, E=2.1e11, G=8.1e10,
    ...                 rho=7850.0, y_axis=[0, 0, 1])
    >>> s.y_axis
    (0.0, 0.0, 1.0)
    """

    A: float
    Iy: float
    Iz: float
    J: float
    E: float
    G: float
    rho: float
    y_axis: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        if self.y_axis is None:
            return
        try:
            y = tuple(float(v) for v in np.asarray(self.y_axis, dtype=float).ravel())
        except (TypeError, ValueError) as exc:
            raise ConfigError(
                f"BeamSection.y_axis: expected 3 numbers, got {self.y_axis!r}") from exc
        object.__setattr__(self, "y_axis", y)


def check_section(section: BeamSection, where: str) -> BeamSection:
    """Raise ``ConfigError`` unless every property of ``section`` is usable.

    Parameters
    ----------
    section : BeamSection
    where : str
        Prefix naming the owner, e.g. ``"link 'boom': sections[1]"``.

    Returns
    -------
    BeamSection
        The same section (for chaining).

    Raises
    ------
    ConfigError
        ``"<where>.<field>: expected a finite value > 0, got ..."`` for A, Iy,
        Iz, J, E, G, rho; or a bad ``y_axis`` (not 3 finite numbers, zero).

    Examples
    --------
    >>> bad = BeamSection(A=-1.0, Iy=1, Iz=1, J=1, E=1, G=1, rho=1)
    >>> check_section(bad, "link 'arm': sections[0]")
    Traceback (most recent call last):
    ...
    pipeline.core.errors.ConfigError: link 'arm': sections[0].A: expected a finite value > 0, got -1.0
    """
    for name in _POSITIVE_FIELDS:
        check_positive(getattr(section, name), f"{where}.{name}")
    if section.y_axis is not None:
        y = np.asarray(section.y_axis, dtype=float)
        if y.shape != (3,) or not np.all(np.isfinite(y)) or not np.any(y):
            raise ConfigError(
                f"{where}.y_axis: expected 3 finite numbers, not all zero, got {section.y_axis!r}")
    return section


def element_frames(directions: np.ndarray, y_axes: np.ndarray, where: str) -> np.ndarray:
    """Local frames of beam elements.

    Parameters
    ----------
    directions : (k, 3) array
        Unit vectors along the elements (local x), link frame.
    y_axes : (k, 3) array
        Orientation vectors per element; rows of NaN select the default rule
        of :class:`BeamSection`.
    where : str
        Prefix for error messages, e.g. ``"link 'boom'"``.

    Returns
    -------
    (k, 3, 3) array
        ``R[e]`` has rows ``e_x, e_y, e_z`` (so ``R[e] @ v`` gives local
        components of a link-frame vector ``v``); proper rotations.

    Raises
    ------
    ConfigError
        If a user ``y_axis`` is parallel to its element.

    Examples
    --------
    >>> R = element_frames(np.array([[1.0, 0, 0]]), np.full((1, 3), np.nan), "beam")
    >>> R[0].astype(int).tolist()
    [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    """
    ex = np.asarray(directions, dtype=float)
    given = np.asarray(y_axes, dtype=float)
    default = ~np.all(np.isfinite(given), axis=1)
    guess = np.where(default[:, None], np.cross([0.0, 0.0, 1.0], ex), given)
    vertical = default & (np.linalg.norm(guess, axis=1) < PARALLEL_SINE)
    guess[vertical] = [0.0, 1.0, 0.0]
    ey = guess - np.einsum("ki,ki->k", guess, ex)[:, None] * ex
    size = np.linalg.norm(ey, axis=1)
    bad = size < PARALLEL_SINE * np.linalg.norm(guess, axis=1)
    if np.any(bad):
        e = int(np.flatnonzero(bad)[0])
        raise ConfigError(
            f"{where}: element {e}: section y_axis {given[e].tolist()} is parallel to the "
            f"element direction {ex[e].tolist()}; expected a vector with a part normal to it")
    ey /= size[:, None]
    return np.stack([ex, ey, np.cross(ex, ey)], axis=1)
