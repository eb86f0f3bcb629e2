"""Drucker-Prager soil (PHYSICS.md §6)."""
