"""How a signal names a component of a marker's position: ``link.frame:x`` (``y``, ``z``),
the grammar every user of it shares (a controller's measured signal, a co-simulation
input, a workflow's series).

>>> marker_component("boom.tip:y")
MarkerComponent(link='boom', frame='tip', axis=1, axes=None)
>>> marker_component("boom.tip", norm=True)        # no component: the distance
MarkerComponent(link='boom', frame='tip', axis=None, axes=None)
>>> marker_component("boom.tip:z@arm", norm=True, axes=True).axes
'arm'
"""

from __future__ import annotations

from typing import NamedTuple

__all__ = ["AXES", "MarkerComponent", "marker_component"]

#: the components of a marker's position
AXES = ("x", "y", "z")


class MarkerComponent(NamedTuple):
    """link, frame; axis 0..2 (x, y, z) or None for the norm; axes: the link whose axes
    the components are in, None for ground's."""

    link: str
    frame: str
    axis: int | None
    axes: str | None


def marker_component(text: str, *, norm: bool = False, axes: bool = False) -> MarkerComponent:
    """The parts of ``text``, ``link.frame:x|y|z`` (with ``norm``: also ``:norm`` or no
    component, the distance from the origin; with ``axes``: a trailing ``@link`` for that
    link's axes, ``@ground`` for ground's). A ValueError says what was expected (the
    caller adds where)."""
    target, colon, comp = text.rpartition(":")
    if not colon:
        target, comp = text, ("norm" if norm else "")
    comp, at, frame_of = comp.partition("@")
    link, dot, frame = target.partition(".")
    choices = AXES + (("norm",) if norm else ())
    if not (dot and link and frame and comp in choices and (at == "" or (axes and frame_of))):
        raise ValueError(
            f"expected 'link.frame:{'|'.join(choices)}'"
            + (" (optionally @<link> for that link's axes)" if axes else "")
            + f", got {text!r}")
    return MarkerComponent(link, frame, None if comp == "norm" else AXES.index(comp),
                           None if frame_of in ("", "ground") else frame_of)
