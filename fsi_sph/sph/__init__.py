"""Shared SPH numerics: smoothing kernels and generic operators."""
