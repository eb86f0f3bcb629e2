"""Fluid-structure coupling: interface forces, sub-cycling, interface power."""
