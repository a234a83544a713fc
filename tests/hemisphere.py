"""Quadrature over the upper hemisphere for the tests' albedo and normalisation checks, and random
upper-hemisphere directions for their pairs."""

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


def upper_directions(rng, n):
    """``n`` random unit directions above the horizon (cos theta >= about 0.05 / |v|): a test's pairs."""
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2]) + 0.05
    return v / np.linalg.norm(v, axis=1, keepdims=True)
