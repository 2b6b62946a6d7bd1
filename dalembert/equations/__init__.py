"""Symbolic equations of motion: Lagrange with multipliers, and the virtual-power check."""

from .lagrange import Equations, derive_equations
from .virtual_power import virtual_power_equations

__all__ = ["Equations", "derive_equations", "virtual_power_equations"]
