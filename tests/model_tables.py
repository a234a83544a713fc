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


# cells evaluated at once: the whole table at once held ~0.25 GB of temporaries (issue 62's 2 GB a worker)
CHUNK = 131072


def evaluate64(model, params, wi, wo):
    """``model`` at ``params`` on the pairs (wi, wo), evaluated in float64: (N, 3) numpy."""
    with jax.enable_x64(True):
        return np.asarray(evaluate(model, to_jax(parse_model(model), params), jnp.asarray(wi, jnp.float64),
                                   jnp.asarray(wo, jnp.float64)))


def write_model_table(path, model, params, noise=0.0):
    """Write the MERL table of ``model`` (a model string or OwnModel) at ``params`` to ``path``,
    each value times exp(``noise`` N(0, 1)) (seeded: the same table every time); returns it."""
    spec = parse_model(model)
    wi, wo, _ = half_diff_grid(*MERL_SHAPE, 1)
    valid = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    rgb = np.zeros((len(wi), 3))
    with jax.enable_x64(True):
        p = to_jax(spec, params)
        for start in range(0, len(wi), CHUNK):
            part = slice(start, start + CHUNK)
            rgb[part] = np.asarray(evaluate(spec, p, jnp.asarray(wi[part]), jnp.asarray(wo[part])))
    if noise:
        rgb *= np.exp(noise * np.random.default_rng(0).standard_normal(rgb.shape))
    rgb[~valid] = 0.0
    write_merl(path, rgb.reshape(MERL_SHAPE + (3,)), valid.reshape(MERL_SHAPE))
    return path


def glb_material(glb):
    """The first material object of the .glb file ``glb`` (its JSON chunk)."""
    data = glb.read_bytes()
    doc = json.loads(data[20:20 + int.from_bytes(data[12:16], "little")].decode())
    return doc["materials"][0]
