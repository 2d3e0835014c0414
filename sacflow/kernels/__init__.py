"""Influence coefficients and convolution operators of the elastic half-space."""
