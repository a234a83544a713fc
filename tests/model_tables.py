"""Measured files the tests write from a model, and the .glb they read back.

``write_model_table``: a MERL table (the documented layout) of a model at the MERL cell
centres, evaluated in float64 -- a measurement whose truth is known.  ``glb_material``:
the first material of a binary glTF file, as written.
"""

import json

import jax
import jax.numpy as jnp
import numpy as np

from brdf import parse_model
from brdf.model import evaluate
from data_loaders.merl import MERL_SHAPE, write_merl
from fitting.synthetic import half_diff_grid
from fitting.transforms import to_jax


def write_model_table(path, model, params):
    """Write the MERL table of ``model`` (a model string or OwnModel) at ``params`` to ``path``; returns it."""
    spec = parse_model(model)
    wi, wo, _ = half_diff_grid(*MERL_SHAPE, 1)
    valid = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    with jax.enable_x64(True):
        rgb = np.asarray(evaluate(spec, to_jax(spec, params), jnp.asarray(wi), jnp.asarray(wo)))
    write_merl(path, np.where(valid[:, None], rgb, 0.0).reshape(MERL_SHAPE + (3,)), valid.reshape(MERL_SHAPE))
    return path


def glb_material(glb):
    """The first material object of the .glb file ``glb`` (its JSON chunk)."""
    data = glb.read_bytes()
    doc = json.loads(data[20:20 + int.from_bytes(data[12:16], "little")].decode())
    return doc["materials"][0]
