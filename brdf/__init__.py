"""Differentiable analytic BRDF models in JAX (docs/models.md).

Terms live in their own modules (specular, fresnel, diffuse, energy,
clearcoat, gltf), each with its declarations (brdf.declare) beside its
formulas; ``brdf.spec`` gathers them into a ``ModelSpec`` and its schema,
``brdf.model`` evaluates it, ``brdf.gltf_material`` converts a fit to glTF.
Importing brdf imports no JAX: the formulas import it when one first runs
(brdf/_lazy.py), so reading the declarations (model strings, the schema) is quick.
"""

__version__ = "0.1.0"

from .constants import ALPHA_MIN, COS_EPS, F0_DIELECTRIC, ROUGHNESS_MIN  # noqa: E402,F401
from .model import (ModelSpec, Param, UnknownModelError, MODEL_EXAMPLES,  # noqa: E402,F401
                    default_params, evaluate, model_string, parameter_schema,
                    parse_model)
