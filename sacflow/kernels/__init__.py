"""Influence coefficients and convolution operators of the elastic half-space (DESIGN §3)."""
