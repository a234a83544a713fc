"""Named constants shared by the JAX models and the GLSL shaders.

The GLSL library (``shaders/common.glsl``) defines the same names with the
same values; a test holds the two files together.
"""

import math

PI = math.pi
INV_PI = 1.0 / math.pi

# Floor on alpha = roughness**2 that every D and G term sees.  The glTF
# specification asks viewers never to evaluate alpha = 0; 1e-3 keeps D below
# 1/(pi alpha^2) ~ 3.2e5 sr^-1, enough for MERL chrome (mirror cells ~ 1e4).
ALPHA_MIN = 1e-3
ROUGHNESS_MIN = math.sqrt(ALPHA_MIN)

# Cosines are clamped to at least this before they divide anything.  It is
# below cos(89.9 deg) = 1.745e-3, so the clamp only acts under the horizon.
COS_EPS = 1e-4

# Normal-incidence reflectance of a dielectric of IOR 1.5 (glTF's default).
F0_DIELECTRIC = 0.04
IOR_DEFAULT = 1.5
