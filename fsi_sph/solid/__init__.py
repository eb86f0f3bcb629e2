"""Total-Lagrangian SPH elastic solids."""
