"""No colour collapse (issue 24): the default (hybrid) loss keeps a dark material's colour.

At one fixed exposure a dark material's image is nearly black, the Neutral tone map's
toe hides its smallest channel, and the hybrid loss could drive that channel to its
bound for a slightly better image elsewhere; at the viewer's exposure it cannot.
"""

import numpy as np
import pytest

from data_loaders.measured import MeasuredBRDF, Provenance
from fitting.fit import fit
from fitting.synthetic import half_diff_grid, synthetic_measured

DARK = {"albedo": [0.012, 0.009, 0.006], "f0": [0.04, 0.04, 0.04], "roughness": 0.4}   # blue / red = 0.5

# The published ABC fit of MERL's black-oxidized-steel (Loew et al. 2012, as tabulated in
# jdupuy/dj_brdf's abc::s_data) with a dark coloured diffuse instead of its own: a broad
# specular tail that one GGX lobe cannot draw, under a dark colour.
ABC = {"kd": np.array(DARK["albedo"]), "a": np.array([1.100971, 1.057305, 1.015528]),
       "b": 30.661055, "c": 1.869546, "ior": 1.660413}


def _chromaticity(rgb):
    rgb = np.asarray(rgb, np.float64)
    return rgb / rgb.sum()


def test_a_dark_coloured_material_keeps_its_chromaticity():
    measured = synthetic_measured("ggx+lambert", DARK, noise=0.05, grid=(24, 24, 48, 1))
    result = fit(measured, "ggx+lambert", loss="hybrid", samples=0)
    np.testing.assert_allclose(_chromaticity(result.parameters["albedo"]), _chromaticity(DARK["albedo"]),
                               rtol=0.02)


def _abc(wi, wo):
    """f of the ABC model (the formula of ../shared/measured/abc-low2012/README.md)."""
    h = wi + wo
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    nl, nv, nh, vh = wi[:, 2], wo[:, 2], h[:, 2], np.sum(wo * h, axis=-1)
    above = (nl > 0) & (nv > 0)
    nl, nv, vh = np.where(above, nl, 1.0), np.where(above, nv, 1.0), np.maximum(vh, 1e-12)
    g2 = ABC["ior"] ** 2 - 1.0 + vh * vh
    g = np.sqrt(g2)
    fresnel = 0.5 * ((g - vh) / (g + vh)) ** 2 * (1 + ((vh * (g + vh) - 1) / (vh * (g - vh) + 1)) ** 2)
    shadow = np.minimum(1.0, np.minimum(2 * nh * nl / vh, 2 * nh * nv / vh))
    d = ABC["a"] / (1.0 + ABC["b"] * (1.0 - nh[:, None])) ** ABC["c"]
    f = ABC["kd"] / np.pi + (fresnel * shadow / (np.pi * nl * nv))[:, None] * d
    return np.where(above[:, None], f, 0.0)


class _Lookup:
    def lookup(self, wi, wo, method=None):
        return _abc(np.asarray(wi, np.float64), np.asarray(wo, np.float64))


@pytest.fixture(scope="module")
def broad_dark():
    wi, wo, weights = half_diff_grid(24, 24, 48, 1)
    valid = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    prov = Provenance(path="<ABC black-oxidized-steel, dark diffuse>", format="synthetic", material="abc-dark",
                      sha256="", units="BRDF (1/sr)")
    return MeasuredBRDF(wi=wi, wo=wo, values=np.where(valid[:, None], _abc(wi, wo), 0.0), weights=weights,
                        valid=valid, isotropic=True, provenance=prov, table=_Lookup())


def test_the_hybrid_fit_drives_no_channel_to_a_bound_the_log_fit_does_not_reach(broad_dark):
    log = fit(broad_dark, "ggx+lambert", loss="log", samples=0).parameters
    hybrid = fit(broad_dark, "ggx+lambert", loss="hybrid", samples=0).parameters
    for name in ("albedo", "f0"):
        reached = np.asarray(log[name]) > 1e-4          # the log fit keeps every channel off its bound ...
        assert reached.all()
        # ... and so does the hybrid fit (at exposure 1 it drove the blue albedo to 2.5e-9)
        assert np.all(np.asarray(hybrid[name]) > 0.5 * np.asarray(log[name])), (name, hybrid[name], log[name])
