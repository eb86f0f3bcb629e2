"""Incompressible SPH fluid (projection method) [F 15-33]."""
