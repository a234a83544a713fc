"""No colour collapse (issue 24): the default (hybrid) loss keeps a dark material's colour.

At one fixed exposure a dark material's image is nearly black, the Neutral tone map's
toe hides its smallest channel, and the hybrid loss could drive that channel to its
bound for a slightly better image elsewhere; at the viewer's exposure it cannot.
"""

import types

import numpy as np
import pytest

from brdf import parse_model
from data_loaders.measured import MeasuredBRDF, Provenance
from fitting._jax import float64
from fitting.fit import fit
from fitting.objective import HybridSet, collapsed, keep_colours
from fitting.synthetic import half_diff_grid, synthetic_measured
from fitting.transforms import from_params, to_params

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


def _blue_albedo_gone(spec, u):
    """``u`` with the blue albedo's unconstrained coordinate far below: albedo b ~ 1e-17
    (from_params clips values to stay off the bounds, so it cannot make one)."""
    base = np.asarray(to_params(spec, u)["albedo"])
    for i in range(len(u)):
        moved = np.array(u, np.float64)
        moved[i] = -40.0
        albedo = np.asarray(to_params(spec, moved)["albedo"])
        if albedo[2] < 1e-12 and np.allclose(albedo[:2], base[:2]):
            return moved
    raise AssertionError("no coordinate of u sets the blue albedo alone")


def _dark_and_collapsed():
    """(ggx+lambert, the dark material's parameter vector, the same with the blue albedo gone)."""
    spec = parse_model("ggx+lambert")
    u = np.asarray(from_params(spec, DARK))
    return spec, u, _blue_albedo_gone(spec, u)


def _weight_only(weight=0.5):
    """A HybridSet of which keep_colours reads only the image weight (the refinements are stand-ins)."""
    return HybridSet(types.SimpleNamespace(size=10), None, np.float64(weight))


@float64
def test_collapsed_names_a_channel_at_a_bound_only_where_the_log_fit_is_not():
    spec, u_log, u_blue_gone = _dark_and_collapsed()
    assert collapsed(spec, u_blue_gone, u_log) == ["albedo"]
    assert collapsed(spec, u_log, u_log) == []
    assert collapsed(spec, u_blue_gone, u_blue_gone) == []      # the log fit reaches that bound too


@float64
def test_keep_colours_lowers_the_image_weight_until_no_channel_collapses():
    spec, u_log, u_gone = _dark_and_collapsed()
    weights = []

    def refine(data, u0):      # a stand-in for the optimizer: the colour collapses above weight 0.2
        weights.append(float(data.weight))
        np.testing.assert_array_equal(u0, u_log)                 # each retry starts from the log fit
        return (u_gone if data.weight > 0.2 else u_log), 0.0, 1, True
    data = _weight_only()
    runs = []
    colour_error = {id(u_gone): 2.0, id(u_log): 1.0}         # the collapse shows in the image's colour
    best = keep_colours(spec, (u_gone, 1.0, True), (u_log, 1.0, True), data, refine, runs, 1,
                        chroma=lambda u: colour_error[id(u)])
    assert weights == [0.0, 0.25, 0.125] and len(runs) == 3     # M1 alone first: the log fit's own colour
    np.testing.assert_array_equal(best[0], u_log)


@float64
def test_keep_colours_keeps_a_channel_at_the_bound_the_log_fit_also_reaches_on_the_same_samples():
    spec, u_start, u_gone = _dark_and_collapsed()          # u_start: a coarse start, not yet converged
    runs = []
    best = keep_colours(spec, (u_gone, 1.0, True), (u_start, 2.0, True),
                        _weight_only(),
                        lambda data, u0: (u_gone, 0.0, 1, True), runs, 1,     # M1 alone goes there too
                        chroma=lambda u: 1.0)
    np.testing.assert_array_equal(best[0], u_gone)
    assert len(runs) == 1


@float64
def test_keep_colours_keeps_a_collapse_that_draws_the_colour_better_than_the_log_fit():
    spec, u_log, u_gone = _dark_and_collapsed()
    runs = []
    best = keep_colours(spec, (u_gone, 1.0, True), (u_log, 2.0, True),
                        _weight_only(),
                        lambda data, u0: (u_log, 0.0, 1, True), runs, 1,
                        chroma=lambda u: 0.5 if u is u_gone else 1.0)   # its image's colour is closer
    np.testing.assert_array_equal(best[0], u_gone)
    assert len(runs) == 1
