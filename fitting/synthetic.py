"""Synthetic measurements generated from a model with known parameters.

Used by the recovery tests and the benchmarks: a MERL-like half/difference
grid (isotropic), or the same grid with every phi_h for anisotropic models,
evaluated with ``brdf.evaluate`` and optionally multiplied by log-normal
noise.  Cell weights are the direction-pair measure of each grid cell.
"""

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Float

from brdf.model import ModelSpec, evaluate, parse_model
from data_loaders.directions import half_diff_to_std
from data_loaders.measured import MeasuredBRDF, Provenance

from ._jax import float64
from .transforms import to_jax


def half_diff_grid(
    n_theta_h: int = 90, n_theta_d: int = 90, n_phi_d: int = 180, n_phi_h: int = 1,
) -> tuple[Float[np.ndarray, "n 3"], Float[np.ndarray, "n 3"], Float[np.ndarray, " n"]]:
    """Cell-centre directions and cell measures of a MERL-style grid.

    theta_h edges are (i/n)^2 pi/2 (fine near the specular peak), theta_d and
    phi_d uniform; phi_d covers [0, pi) when n_phi_h == 1 (isotropic data,
    reciprocity folds the other half) and [0, 2 pi) otherwise, with n_phi_h
    uniform phi_h cells.  Returns wi, wo (N, 3) and weights (N,) in sr^2 whose
    sum is (2 pi)^2 over the full hemisphere pair (cells below the horizon
    included, as in MERL).
    """
    i = np.arange(n_theta_h)
    j = np.arange(n_theta_d)
    th_edges = (np.arange(n_theta_h + 1) / n_theta_h) ** 2 * np.pi / 2
    td_edges = np.arange(n_theta_d + 1) / n_theta_d * np.pi / 2
    th = ((i + 0.5) / n_theta_h) ** 2 * np.pi / 2
    td = (j + 0.5) / n_theta_d * np.pi / 2
    phi_d_range = np.pi if n_phi_h == 1 else 2 * np.pi
    pd = (np.arange(n_phi_d) + 0.5) / n_phi_d * phi_d_range
    ph = (np.arange(n_phi_h) + 0.5) / n_phi_h * 2 * np.pi if n_phi_h > 1 else np.zeros(1)
    w_h = np.cos(th_edges[:-1]) - np.cos(th_edges[1:])
    w_d = np.sin(td_edges[1:]) ** 2 - np.sin(td_edges[:-1]) ** 2
    TH, PH, TD, PD = np.meshgrid(th, ph, td, pd, indexing="ij")
    wi, wo = half_diff_to_std(TH.ravel(), PH.ravel(), TD.ravel(), PD.ravel())
    # d(w_i) d(w_o) = 4 cos td sin td sin th dth dph dtd dpd; per cell
    # (dcos th)(d sin^2 td) dph dpd (x 2 for the folded phi_d half), scaled
    # by 1/2 like MERL's weights so that the whole grid sums to (2 pi)^2.
    fold = 2.0 if n_phi_h == 1 else 1.0
    cell = (fold * (2 * np.pi / n_phi_h) * (phi_d_range / n_phi_d)
            * w_h[:, None, None, None] * w_d[None, None, :, None])
    weights = np.broadcast_to(cell, TH.shape).ravel()
    return wi, wo, weights


@float64
def synthetic_measured(spec: ModelSpec | str, parameters: dict[str, float | list[float]], noise: float = 0.0,
                       seed: int = 0, grid: tuple[int, int, int, int] | None = None,
                       material: str = "synthetic") -> MeasuredBRDF:
    """A MeasuredBRDF of ``spec`` at ``parameters`` ({name: float or [r, g, b]}).

    ``noise`` is the standard deviation of multiplicative log-normal noise
    (0.02 = 2 %).  ``grid`` = (n_theta_h, n_theta_d, n_phi_d, n_phi_h); the
    default is (45, 45, 90, 1) for isotropic and (32, 32, 64, 16) for
    anisotropic models.  Cells with a direction below the horizon are invalid.
    The model is evaluated in float64 (as the fitter runs).
    The table attribute is a nearest-sample lookup over the generated pairs
    is not provided: ``lookup`` evaluates the generating model exactly.
    """
    spec = parse_model(spec)
    if grid is None:
        grid = (32, 32, 64, 16) if spec.anisotropic else (45, 45, 90, 1)
    wi, wo, weights = half_diff_grid(*grid)
    params = to_jax(spec, parameters)
    model = jax.jit(lambda a, b: evaluate(spec, params, a, b))
    values = np.asarray(model(jnp.asarray(wi), jnp.asarray(wo)), dtype=np.float64)
    if noise:
        rng = np.random.default_rng(seed)
        values = values * np.exp(noise * rng.standard_normal(values.shape))
    valid = (wi[:, 2] > 0) & (wo[:, 2] > 0) & np.all(np.isfinite(values), axis=1)
    values = np.where(valid[:, None], values, 0.0)
    table = _ModelTable(model)
    prov = Provenance(path=f"<synthetic {spec}>", format="synthetic", material=material,
                      sha256="", units=f"BRDF (1/sr) of {spec} with {noise:.3g} log-normal noise")
    return MeasuredBRDF(wi=wi, wo=wo, values=values, weights=weights, valid=valid,
                        isotropic=not spec.anisotropic, provenance=prov, table=table)


class _ModelTable:
    """lookup() of a synthetic measurement: the noiseless generating model."""

    def __init__(self, model):
        self._model = model

    @float64
    def lookup(self, wi, wo, method=None):
        return np.asarray(self._model(jnp.asarray(wi), jnp.asarray(wo)), dtype=np.float64)
