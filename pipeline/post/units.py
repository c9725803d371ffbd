"""Display units of plotted series: SI values in, the engineer's units out (numpy only)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

LENGTH = {"m": 1.0, "cm": 1e2, "mm": 1e3}
FORCE = {"N": 1.0, "kN": 1e-3}
ANGLE = {"rad": 1.0, "deg": 180.0 / np.pi}
STRESS = {"Pa": 1.0, "kPa": 1e-3, "MPa": 1e-6}


@dataclass(frozen=True)
class DisplayUnits:
    """Units plots are drawn in: length (m, cm, mm), force (N, kN), angle (rad, deg),
    stress (Pa, kPa, MPa; MPa by default, as engineers read it)."""

    length: str = "m"
    force: str = "N"
    angle: str = "rad"
    stress: str = "MPa"


def to_display(values, unit: str, units: DisplayUnits) -> tuple[np.ndarray, str]:
    """(values, unit) of an SI series converted to ``units``.

    Lengths, forces and angles convert, also as the numerator of a rate ("m/s",
    "rad/s²"); moments take the force unit and stay per metre ("N m" -> "kN m", whatever
    the length unit: a torque in kN mm reads as a thousand times too large at a glance);
    other units pass unchanged.

    >>> to_display([0.5], "rad", DisplayUnits(angle="deg"))[0].round(4).tolist()
    [28.6479]
    >>> to_display([2500.0], "N m", DisplayUnits(force="kN", length="mm"))
    (array([2.5]), 'kN m')
    >>> to_display([0.01], "m/s", DisplayUnits(length="mm"))
    (array([10.]), 'mm/s')
    >>> to_display([2.5e7], "Pa", DisplayUnits())
    (array([25.]), 'MPa')
    """
    v = np.asarray(values, dtype=float)
    head, slash, tail = unit.partition("/")
    if head == "m":
        return v * LENGTH[units.length], units.length + slash + tail
    if head == "rad":
        return v * ANGLE[units.angle], units.angle + slash + tail
    if head == "N":
        return v * FORCE[units.force], units.force + slash + tail
    if head == "Pa":
        return v * STRESS[units.stress], units.stress + slash + tail
    if head == "N m":  # moments: the force unit times metres (kN m, as engineers read them)
        return v * FORCE[units.force], f"{units.force} m" + slash + tail
    return v, unit
