"""Differentiable analytic BRDF models in JAX (see ../shared/DESIGN.md).

Terms live in their own modules (specular, fresnel, diffuse, energy,
clearcoat, gltf); ``brdf.model`` composes them from a ``ModelSpec``.
"""

__version__ = "0.1.0"

from .constants import ALPHA_MIN, COS_EPS, F0_DIELECTRIC, ROUGHNESS_MIN  # noqa: E402,F401
from .model import (ModelSpec, Param, UnknownModelError, MODEL_EXAMPLES,  # noqa: E402,F401
                    default_params, evaluate, model_string, parameter_schema,
                    parse_model)
