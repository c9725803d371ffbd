"""Reduced-link artifact: mass invariants, modal data, frames (the FE/MBS seam)."""

from pipeline.invariants.reduced_link import FrameModes, ReducedLink
from pipeline.invariants.store import load_reduced_link, save_reduced_link

__all__ = ["FrameModes", "ReducedLink", "load_reduced_link", "save_reduced_link"]
