"""Lagrange dynamics of rigid/flexible closed-loop machines (DESIGN §4)."""

from pipeline.dynamics.system import BodyMass, System, rigid_C

__all__ = ["BodyMass", "System", "rigid_C"]
