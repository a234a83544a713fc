"""Quadrature over the upper hemisphere for the tests' albedo and normalisation checks."""

import math

import numpy as np


def hemisphere(n=400, theta_max=math.pi / 2):
    """Directions and solid-angle weights of a (theta, phi) Gauss-Legendre grid, theta in [0, theta_max]."""
    x, w = np.polynomial.legendre.leggauss(n)
    theta, wt = (x + 1) * theta_max / 2, w * theta_max / 2
    phi, wp = (x + 1) * math.pi, w * math.pi
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], axis=-1).reshape(-1, 3)
    return d, (np.outer(wt * np.sin(theta), wp)).reshape(-1)
