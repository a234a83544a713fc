"""Reciprocity, gradients and float32 of every model string (brdf.evaluate).

- Reciprocity f(wi, wo) == f(wo, wi) (1e-10 relative, float64) for every
  diffuse lobe and every model in MODEL_EXAMPLES plus COMBINATIONS, at random
  parameters inside the schema bounds.  Two terms are not reciprocal by
  construction and are tested for exactly the asymmetry their formula gives:
  the KHR_materials_clearcoat layering (weight clearcoat * Fc(n.wo)) and the
  Turquin compensation (factor 1 + F0 (1 - E(n.wo)) / E(n.wo)); OpenPBR's
  non-metal weighs its base by 1 - E(n.wo) (tests/test_openpbr_nonmetal.py holds that
  asymmetry), its dielectric alone is tested here; OpenPBR's coat (coat_weight 0 here) as
  well (tests/test_openpbr_coat.py), and the Principled BSDF's (tests/test_principled.py).
- jax.grad of sum(log1p(f)) with respect to every parameter agrees with
  central finite differences (h = 1e-6, rtol 1e-5) at random configurations,
  and is finite at the edge cases DESIGN.md names (n.h = 1, roughness at its
  floor, theta up to 89.9 deg, anisotropy 0 and rotation 0, bounds).
- evaluate runs in float32 (finite, float32 out, close to float64).

One jitted value-and-grad kernel per model string serves all three (the
direction arrays always have N_PAIRS rows), which keeps compilation to one
per model.
"""

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import brdf
from brdf import clearcoat, diffuse, energy
from fitting.objective import is_reciprocal

N_PAIRS = 8
# LLVM optimisation level 0: cuts the compile time that dominates this file by ~1/3
# and does not change IEEE semantics (XLA CPU fast-math stays off).
FAST_COMPILE = {"xla_backend_optimization_level": 0}

# Model strings beyond MODEL_EXAMPLES whose term combinations are not covered there.
COMBINATIONS = (
    "ggx+oren_nayar+separable+f90",
    "ggx_aniso+frostbite+gltf_aniso+separable",
    "ggx+burley+dielectric+coupled+ms",
    "ggx_aniso+conductor+ms",
    "gltf+ior+specular+aniso+clearcoat",
)
ALL_MODELS = tuple(brdf.MODEL_EXAMPLES) + COMBINATIONS
NON_RECIPROCAL = {m for m in ALL_MODELS if "clearcoat" in m or "turquin" in m}


def schema(model):
    return brdf.parse_model(model).schema()


def unflatten(model, x):
    out, i = {}, 0
    for p in schema(model):
        out[p.name] = x[i] if p.size == 1 else x[i:i + 3]
        i += p.size
    return out


def flatten(model, params):
    return np.concatenate([np.broadcast_to(np.asarray(params[p.name], float), (p.size,))
                           for p in schema(model)])


def random_x(model, rng, margin=0.0):
    """A flat parameter vector uniform in [lower, upper] shrunk by ``margin`` of the range."""
    parts = []
    for p in schema(model):
        lo, hi = p.lower + margin * (p.upper - p.lower), p.upper - margin * (p.upper - p.lower)
        parts.append(rng.uniform(lo, hi, p.size))
    return np.concatenate(parts)


def set_param(model, x, **kw):
    p = unflatten(model, np.array(x, float))
    for k, v in kw.items():
        p[k] = np.broadcast_to(np.asarray(v, float), np.shape(p[k]))
    return flatten(model, p)


def random_dirs(rng, n=N_PAIRS, min_cos=0.05):
    cos = rng.uniform(min_cos, 1.0, n)
    phi = rng.uniform(0.0, 2 * np.pi, n)
    s = np.sqrt(1 - cos * cos)
    return np.stack([s * np.cos(phi), s * np.sin(phi), cos], -1)


@functools.lru_cache(maxsize=None)
def kernel(model):
    """jit((x, wi, wo) -> ((sum log1p f, (f, f_rev)), d/dx)) for one model string.

    f_rev is the fitter's fast path for non-reciprocal models,
    evaluate_geometry(geometry(wi, wo).reversed()), which must equal f(wo, wi)
    (computed for NON_RECIPROCAL models only; f elsewhere).
    """
    spec = brdf.parse_model(model)

    def loss(x, wi, wo):
        p = unflatten(model, x)
        f = brdf.evaluate(spec, p, wi, wo)
        f_rev = f
        if model in NON_RECIPROCAL:
            f_rev = brdf.model.evaluate_geometry(spec, p, brdf.model.geometry(wi, wo).reversed())
        return jnp.sum(jnp.log1p(f)), (f, f_rev)
    return jax.jit(jax.value_and_grad(loss, has_aux=True), compiler_options=FAST_COMPILE)


def values(model, x, wi, wo):
    (_, (f, _)), _ = kernel(model)(x, wi, wo)
    return np.asarray(f)


def values_reversed_geometry(model, x, wi, wo):
    (_, (_, f_rev)), _ = kernel(model)(x, wi, wo)
    return np.asarray(f_rev)


def seed(model, salt):
    """A deterministic per-test seed (Python's str hash is randomised per process)."""
    return sum(i * ord(c) for i, c in enumerate(model, 1)) * 7919 + salt


# --- reciprocity -------------------------------------------------------------------

def sym_pairs(rng):
    return random_dirs(rng), random_dirs(rng)


@pytest.mark.parametrize("name", ["lambert", "burley", "frostbite", "cod_wwii", "oren_nayar",
                                  "oren_nayar_full"])
def test_diffuse_reciprocity(name):
    rng = np.random.default_rng(1)
    wi, wo = random_dirs(rng, 256, 0.01), random_dirs(rng, 256, 0.01)
    rho = np.array([0.9, 0.5, 0.2])

    def f(a, b):
        h = (a + b) / np.linalg.norm(a + b, axis=-1, keepdims=True)
        nl, nv, lh, nh = a[:, 2], b[:, 2], np.sum(a * h, -1), h[:, 2]
        p = 0.37   # roughness, alpha or sigma
        return np.asarray({
            "lambert": lambda: diffuse.lambert(rho, nl, nv),
            "burley": lambda: diffuse.burley(rho, p, nl, nv, lh),
            "frostbite": lambda: diffuse.frostbite(rho, p, nl, nv, lh),
            "cod_wwii": lambda: diffuse.cod_wwii(rho, p, nl, nv, lh, nh),
            "oren_nayar": lambda: diffuse.oren_nayar(rho, 0.8, a, b),
            "oren_nayar_full": lambda: diffuse.oren_nayar_full(rho, 0.8, a, b),
        }[name]())
    np.testing.assert_allclose(f(wi, wo), f(wo, wi), rtol=1e-10, atol=0)


@pytest.mark.parametrize("model", [m for m in ALL_MODELS if not m.endswith("+mx")   # +mx: its comp is at n.v, as
                                   and not (m.startswith("principled") and m.endswith("+ms"))])   # Turquin's, and
def test_reciprocity(model):     # Cycles' Multiscatter GGX (tests/test_openpbr_mx.py, test_principled.py: asymmetry)
    rng = np.random.default_rng(seed(model, 1))
    for _trial in range(3):
        x = random_x(model, rng)
        # the two non-reciprocal terms switched off (their asymmetry is tested below):
        if "clearcoat" in model:
            x = set_param(model, x, clearcoat=0.0)       # no coat: the base must be reciprocal
        if "turquin" in model:
            x = turquin_off(model, x)
        if model.startswith(("openpbr", "principled")) and model.endswith("+coat"):   # the coat's layer: as
            x = set_param(model, x, coat_weight=0.0)     # the base's (weighed by the view side's albedo), off
        if model.endswith("+fuzz") or model == "principled+nonmetal+sheen":   # the fuzz's, the sheen's layer and
            # lobe (in the view's frame), off
            x = set_param(model, x, fuzz_weight=0.0)
        if model.startswith(("openpbr+nonmetal", "principled+nonmetal")):   # MaterialX's layer weighs the base by the view
            x = set_param(model, x, base_color=0.0, specular_ior=1.5)   # side's albedo: the dielectric alone
        wi, wo = sym_pairs(rng)
        a, b = values(model, x, wi, wo), values(model, x, wo, wi)
        assert np.all(a > 0), model
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=0, err_msg=model)


@pytest.mark.parametrize("model", ALL_MODELS)
def test_the_fitter_evaluates_both_orientations_of_every_model_that_is_not_reciprocal(model):
    """fitting.objective.is_reciprocal (each term's ``reciprocal``) against the formula, every
    term on, at random parameters: where it says reciprocal, f(wi, wo) = f(wo, wi) (the fit
    evaluates one orientation for both); where it does not, the two differ (OpenPBR's
    non-metal, its coats and +mx were fitted in one orientation before)."""
    rng = np.random.default_rng(seed(model, 3))
    x = random_x(model, rng, margin=0.1)
    wi, wo = sym_pairs(rng)
    a, b = values(model, x, wi, wo), values(model, x, wo, wi)
    if is_reciprocal(brdf.parse_model(model)):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=0, err_msg=model)
    else:
        assert np.max(np.abs(a - b)) > 1e-6 * np.max(np.abs(a)), model


def turquin_off(model, x):
    """x with F0 = 0, where Turquin's factor is 1 (glTF's engines' reading: the blended F0, a
    metal's baseColor, a dielectric's F0(ior))."""
    if not model.startswith("gltf"):
        return set_param(model, x, f0=0.0)
    return set_param(model, x, **({"base_color": 0.0} if "+metal" in model else {"ior": 1.0}))


def fc_reference(mu):
    """REFERENCE.md s.6: Fc = 0.04 + 0.96 (1 - |n.v|)^5."""
    return 0.04 + 0.96 * (1.0 - np.abs(mu)) ** 5


@pytest.mark.parametrize("model", sorted(m for m in ALL_MODELS if "clearcoat" in m))
def test_clearcoat_asymmetry(model):
    """f(wi, wo) - f(wo, wi) = c (Fc(n.wo) - Fc(n.wi)) (coat - base) with base, coat reciprocal."""
    rng = np.random.default_rng(seed(model, 2))
    x = set_param(model, random_x(model, rng), clearcoat=0.83)
    if "turquin" in model:                    # a reciprocal base (Turquin's factor 1)
        x = turquin_off(model, x)
    p = unflatten(model, x)
    wi, wo = sym_pairs(rng)
    base = values(model, set_param(model, x, clearcoat=0.0), wi, wo)
    h = (wi + wo) / np.linalg.norm(wi + wo, axis=-1, keepdims=True)
    coat = np.asarray(clearcoat.clearcoat_brdf(wi[:, 2], wo[:, 2], h[:, 2], p["clearcoat_roughness"]))
    expected = 0.83 * (fc_reference(wo[:, 2]) - fc_reference(wi[:, 2]))[:, None] * (coat[:, None] - base)
    diff = values(model, x, wi, wo) - values(model, x, wo, wi)
    np.testing.assert_allclose(diff, expected, rtol=1e-9, atol=1e-12 * np.abs(base).max())
    assert np.abs(diff).max() > 1e-6      # the layering is really not reciprocal
    check_reversed_geometry(model, x, wi, wo)


def check_reversed_geometry(model, x, wi, wo):
    """The fitter's fast path: evaluate_geometry on geometry(wi, wo).reversed() is f(wo, wi)."""
    np.testing.assert_allclose(values_reversed_geometry(model, x, wi, wo), values(model, x, wo, wi),
                               rtol=1e-12)


def test_turquin_asymmetry():
    """f = f_ss T(n.wo) + f_d: f(wi, wo) - f(wo, wi) = f_ss (T(n.wo) - T(n.wi))."""
    model = "ggx+lambert+turquin"
    rng = np.random.default_rng(3)
    x = random_x(model, rng)
    p = unflatten(model, x)
    wi, wo = sym_pairs(rng)
    f_plain = values("ggx+lambert", x, wi, wo)            # same schema, no compensation
    f_ss = f_plain - np.asarray(p["albedo"]) / np.pi
    t = lambda mu: np.asarray(energy.turquin_factor(mu, p["roughness"], p["f0"]))
    diff = values(model, x, wi, wo) - values(model, x, wo, wi)
    np.testing.assert_allclose(diff, f_ss * (t(wo[:, 2]) - t(wi[:, 2])), rtol=1e-9,
                               atol=1e-12 * np.abs(f_plain).max())
    assert np.abs(diff).max() > 1e-6
    # and the whole model is f_ss T(n.wo) + albedo / pi
    np.testing.assert_allclose(values(model, x, wi, wo), f_ss * t(wo[:, 2]) + np.asarray(p["albedo"]) / np.pi,
                               rtol=1e-10)
    check_reversed_geometry(model, x, wi, wo)


# --- gradients ------------------------------------------------------------------------

FD_STEP = 1e-6


@pytest.mark.parametrize("model", ALL_MODELS)
def test_gradient_matches_finite_differences(model):
    rng = np.random.default_rng(seed(model, 4))
    k = kernel(model)
    for _trial in range(2):
        x = random_x(model, rng, margin=0.05)
        wi, wo = random_dirs(rng), random_dirs(rng)
        (loss, _), g = k(x, wi, wo)
        g = np.asarray(g)
        fd = np.empty_like(g)
        for j in range(len(x)):
            e = np.zeros_like(x)
            e[j] = FD_STEP
            (lp, _), _ = k(x + e, wi, wo)
            (lm, _), _ = k(x - e, wi, wo)
            fd[j] = (float(lp) - float(lm)) / (2 * FD_STEP)
        names = [f"{p.name}[{c}]" if p.size == 3 else p.name for p in schema(model) for c in range(p.size)]
        np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-7 * (1.0 + abs(float(loss))),
                                   err_msg=f"{model}: {names}")
        # every parameter matters to the loss somewhere (no silently ignored entry)
        assert np.all(np.abs(g) > 0), (model, [n for n, v in zip(names, g) if v == 0])


def grazing(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def mirror(theta_deg, phi_deg=0.0):
    return grazing(theta_deg, phi_deg), grazing(theta_deg, phi_deg + 180.0)


# Direction pairs (wi, wo), N_PAIRS of them: n.h = 1 cases and grazing ones.
EDGE_PAIRS = [
    (np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0])),      # wi = wo = n
    mirror(17.0), mirror(60.0, 33.0), mirror(89.9, 120.0),        # n.h = 1
    (grazing(89.9, 0.0), grazing(89.9, 90.0)),
    (grazing(89.9, 10.0), grazing(89.9, 10.0)),                   # wi = wo at grazing
    (grazing(89.9, 0.0), np.array([0.0, 0.0, 1.0])),
    (grazing(0.01, 0.0), grazing(45.0, 180.0)),
]
EDGE_WI = np.stack([p[0] for p in EDGE_PAIRS])
EDGE_WO = np.stack([p[1] for p in EDGE_PAIRS])


def edge_configs(model):
    """Parameter vectors at the edges: floors, bounds, zero anisotropy / rotation."""
    sch = schema(model)
    names = [p.name for p in sch]
    rng = np.random.default_rng(seed(model, 5))
    lower = flatten(model, {p.name: p.lower for p in sch})
    upper = flatten(model, {p.name: p.upper for p in sch})
    default = flatten(model, {p.name: p.default for p in sch})
    floor = set_param(model, random_x(model, rng, 0.05), roughness=brdf.ROUGHNESS_MIN)
    if "clearcoat_roughness" in names:
        floor = set_param(model, floor, clearcoat=0.7, clearcoat_roughness=brdf.ROUGHNESS_MIN)
    out = {"lower": lower, "upper": upper, "default": default, "roughness_floor": floor}
    if "anisotropy" in names:
        out["aniso0"] = set_param(model, random_x(model, rng, 0.05), anisotropy=0.0, rotation=0.0)
        out["aniso0_floor"] = set_param(model, floor, anisotropy=0.0, rotation=0.0)
    return out


@pytest.mark.parametrize("model", ALL_MODELS)
def test_gradient_finite_at_edges(model):
    k = kernel(model)
    for label, x in edge_configs(model).items():
        for wi, wo in ((EDGE_WI, EDGE_WO), (EDGE_WO, EDGE_WI)):
            (loss, (f, _)), g = k(x, wi, wo)
            assert np.all(np.isfinite(np.asarray(f))), (model, label, np.asarray(f))
            assert np.all(np.asarray(f) >= 0.0), (model, label)
            assert np.all(np.isfinite(np.asarray(g))), (model, label, np.asarray(g))


@pytest.mark.parametrize("model", ALL_MODELS)
def test_gradient_finite_below_horizon(model):
    # pairs with a direction under the surface give 0 and must not poison a batch gradient
    k = kernel(model)
    wi = EDGE_WI.copy()
    wi[:, 2] *= -1.0
    wi[0] = [0.0, 0.0, -1.0]
    x = flatten(model, {p.name: p.default for p in schema(model)})
    (loss, (f, _)), g = k(x, wi, EDGE_WO)
    assert np.all(np.asarray(f) == 0.0)
    assert np.all(np.isfinite(np.asarray(g))), (model, np.asarray(g))


# --- float32 ---------------------------------------------------------------------------

@functools.lru_cache(maxsize=None)
def float32_results():
    """{model: [(label, f32 output, x, wi, wo)]} from one jitted float32 evaluation of every
    model: a random configuration, then every edge configuration in both direction orders.

    One compile for all models (vmapped over the rows of each model); a jit per
    model would cost 23 compiles.
    """
    rng = np.random.default_rng(6)
    cases = {}
    for model in ALL_MODELS:
        rows = [("random", random_x(model, rng, margin=0.05), random_dirs(rng, min_cos=0.1),
                 random_dirs(rng, min_cos=0.1))]
        for label, xe in edge_configs(model).items():
            rows += [(label, xe, EDGE_WI, EDGE_WO), (label + "/swapped", xe, EDGE_WO, EDGE_WI)]
        cases[model] = rows

    def run(batches):
        return {m: jax.vmap(lambda x, a, b, m=m: brdf.evaluate(brdf.parse_model(m), unflatten(m, x), a, b))(
            *batches[m]) for m in ALL_MODELS}
    batches = {m: tuple(jnp.asarray(np.stack([r[k] for r in rows]), jnp.float32) for k in (1, 2, 3))
               for m, rows in cases.items()}
    out = jax.jit(run, compiler_options=FAST_COMPILE)(batches)
    return {m: [(r[0], np.asarray(o), r[1], r[2], r[3]) for r, o in zip(cases[m], out[m])]
            for m in ALL_MODELS}


@pytest.mark.parametrize("model", ALL_MODELS)
def test_float32(model):
    rows = float32_results()[model]
    for label, out, _x, _wi, _wo in rows:
        assert out.dtype == np.float32, (model, label)
        assert np.all(np.isfinite(out)), (model, label, out)
        assert np.all(out >= 0.0), (model, label, out)
    # away from the edges, float32 agrees with float64 (inputs rounded to float32 first)
    label, out, x, wi, wo = rows[0]
    r32 = lambda a: np.asarray(a, np.float32).astype(np.float64)
    np.testing.assert_allclose(out, values(model, r32(x), r32(wi), r32(wo)), rtol=1e-3, atol=1e-6)
