"""Evaluate GLSL BRDF terms and whole ModelSpecs on arbitrary inputs, on the GPU.

A compute shader (OpenGL 4.3; Mesa llvmpipe offers 4.5) reads one record per
item from a std430 buffer, evaluates a GLSL expression over the library, and
writes a vec4 per item; the result comes back as a numpy array.  This is how
the tests hold the GLSL library and the JAX models to the same numbers:

    >>> evaluate_glsl("ggx_ndf(n_dot_h, alpha)", n_dot_h=nh, alpha=a)        # (N,)
    >>> evaluate_model("ggx+lambert+ms", params, wi, wo)                      # (N, 3)

Inputs are float32 arrays of shape (N,) (GLSL float) or (N, k), k in 2..4
(vecK); scalars are broadcast.  Model parameters may be shared (scalar / RGB,
sent through the same std140 uniform block the renderer uses) or given per
pair ((N,) / (N, 3), sent as an std140 array of BrdfParams in a buffer).
"""

import numpy as np

from brdf.model import parse_model

from . import library, own_glsl, tables
from .gl import compute_program, get_context

WORKGROUP = 64
MAX_GROUPS = 65535

#: What every expression can call: the whole library except the composition
#: (model.glsl needs a spec's BrdfParams).
TERM_INCLUDES = ("specular.glsl", "fresnel.glsl", "diffuse.glsl", "energy.glsl",
                 "clearcoat.glsl", "gltf.glsl", "openpbr.glsl", "principled.glsl")

_STORE = """
vec4 harness_pad(float x) { return vec4(x, 0.0, 0.0, 0.0); }
vec4 harness_pad(vec2 x) { return vec4(x, 0.0, 0.0); }
vec4 harness_pad(vec3 x) { return vec4(x, 0.0); }
vec4 harness_pad(vec4 x) { return x; }
"""

_GLSL_TYPES = {1: "float", 2: "vec2", 3: "vec3", 4: "vec4"}


def _prepare_inputs(inputs):
    """{name: (N, k) float32} with a common N (scalars broadcast)."""
    arrays = {k: np.asarray(v, dtype=np.float32) for k, v in inputs.items()}
    lengths = {a.shape[0] for a in arrays.values() if a.ndim >= 1}
    if not lengths:
        raise ValueError("at least one input must be an array of N items")
    if len(lengths) != 1:
        raise ValueError(f"inputs have different lengths: { {k: a.shape for k, a in arrays.items()} }")
    (n,) = lengths
    out = {}
    for name, a in arrays.items():
        if a.ndim == 0:
            a = np.full((n, 1), a, dtype=np.float32)
        elif a.ndim == 1:
            a = a[:, None]
        if a.ndim != 2 or a.shape[1] not in _GLSL_TYPES:
            raise ValueError(f"input {name!r}: shape {a.shape}; want (N,) or (N, 2..4)")
        out[name] = a
    return n, out


def _run(source, line_map, n, record, params_bytes=None, block_bytes=None):
    ctx = get_context()
    program = compute_program(source, line_map)
    tables.bind_tables(ctx, program)
    in_buf = ctx.buffer(np.ascontiguousarray(record, dtype=np.float32).tobytes() or b"\0" * 4)
    out_buf = ctx.buffer(reserve=max(n, 1) * 16)
    in_buf.bind_to_storage_buffer(0)
    out_buf.bind_to_storage_buffer(1)
    extra = []
    if params_bytes is not None:
        pbuf = ctx.buffer(params_bytes)
        pbuf.bind_to_storage_buffer(2)
        extra.append(pbuf)
    if block_bytes is not None:
        ubuf = ctx.buffer(block_bytes)
        ubuf.bind_to_uniform_block(library.MATERIAL_BLOCK_BINDING)
        extra.append(ubuf)
    program["harness_n"].value = n
    per_dispatch = MAX_GROUPS * WORKGROUP
    for start in range(0, n, per_dispatch):
        count = min(per_dispatch, n - start)
        program["harness_offset"].value = start
        program.run((count + WORKGROUP - 1) // WORKGROUP)
    ctx.finish()
    result = np.frombuffer(out_buf.read(), dtype=np.float32).reshape(-1, 4)[:n].copy()
    for b in [in_buf, out_buf] + extra:
        b.release()
    return result


def _kernel(expression, inputs, includes, spec=None, defines=None, prelude=""):
    """Source of the compute kernel evaluating ``expression`` per item."""
    stride = sum(a.shape[1] for a in inputs.values())
    loads, offset = [], 0
    for name, a in inputs.items():
        k = a.shape[1]
        comps = ", ".join(f"harness_in[harness_base + {offset + j}u]" for j in range(k))
        loads.append(f"    {_GLSL_TYPES[k]} {name} = {_GLSL_TYPES[k]}({comps});")
        offset += k
    body = "\n".join(
        [f'#include "{f}"' for f in includes]
        + [f"layout(local_size_x = {WORKGROUP}) in;",
           "layout(std430, binding = 0) readonly buffer HarnessInput { float harness_in[]; };",
           "layout(std430, binding = 1) writeonly buffer HarnessOutput { vec4 harness_out[]; };",
           "uniform uint harness_n;",
           "uniform uint harness_offset;",
           _STORE, prelude,
           "void main() {",
           "    uint harness_i = gl_GlobalInvocationID.x + harness_offset;",
           "    if (harness_i >= harness_n) return;",
           f"    uint harness_base = harness_i * {max(stride, 1)}u;"]
        + loads
        + [f"    harness_out[harness_i] = harness_pad({expression});", "}"])
    return library.build_source(body, spec=spec, defines=defines, name="<parity kernel>")


def evaluate_glsl(expression, inputs=None, components=1, includes=TERM_INCLUDES,
                  defines=None, prelude="", **kw_inputs):
    """Evaluate a GLSL expression over the library for N items.

    ``inputs`` (or keyword arguments) maps GLSL variable names to arrays of
    shape (N,) or (N, k); the expression may call any library function, and
    any function of ``prelude`` (GLSL source compiled before the kernel: code
    from elsewhere, such as MaterialX's, held against the library's).
    Returns float32 (N,) if ``components`` is 1 else (N, components).
    """
    inputs = dict(inputs or {}, **kw_inputs)
    n, arrays = _prepare_inputs(inputs)
    record = np.concatenate(list(arrays.values()), axis=1) if arrays else np.zeros((n, 0), np.float32)
    source, line_map = _kernel(expression, arrays, includes, defines=defines, prelude=prelude)
    out = _run(source, line_map, n, record)
    return out[:, 0] if components == 1 else out[:, :components]


def _is_shared(spec, params):
    for p in spec.schema():
        shape = np.shape(params[p.name])
        if shape not in ((), (1,), (p.size,)):
            return False
    return True


def evaluate_model(spec, params, wi, wo, defines=None):
    """The BRDF of ``spec`` (model.glsl's brdf_evaluate) at N pairs: float32 (N, 3).

    ``params`` maps every schema name to a value; shared values go through the
    renderer's uniform block, per-pair values ((N,) or (N, 3)) through an
    std140 array of BrdfParams.
    """
    spec = parse_model(spec)
    wi = np.asarray(wi, dtype=np.float32).reshape(-1, 3)
    wo = np.asarray(wo, dtype=np.float32).reshape(-1, 3)
    if wi.shape != wo.shape:
        raise ValueError(f"wi {wi.shape} and wo {wo.shape} differ")
    n = wi.shape[0]
    record = np.concatenate([wi, wo], axis=1)
    arrays = {"wi": wi, "wo": wo}
    includes = ("model.glsl",)
    if _is_shared(spec, params):
        prelude = library.uniform_block_source(spec)
        source, line_map = _kernel("brdf_evaluate(material, wi, wo)", arrays, includes,
                                   spec=spec, defines=defines, prelude=prelude)
        buffers = {"block_bytes": library.pack_params(spec, params)}
    else:
        prelude = ("layout(std140, binding = 2) readonly buffer HarnessParams "
                   "{ BrdfParams harness_params[]; };")
        source, line_map = _kernel("brdf_evaluate(harness_params[harness_i], wi, wo)", arrays, includes,
                                   spec=spec, defines=defines, prelude=prelude)
        buffers = {"params_bytes": library.pack_params_array(spec, params, n)}
    with own_glsl.compile_errors(spec):      # a model of one's own: its glsl= named in one line
        out = _run(source, line_map, n, record, **buffers)
    return out[:, :3]


# --- test inputs and comparison (shared by the tests and `python -m shaders.parity`) ---

#: The parity criterion of the tests: relative where |JAX| exceeds BIG, absolute elsewhere.
BIG = 1e-4
REL_TOL = 1e-4
ABS_TOL = 1e-6


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _sphere_dir(theta, phi):
    s = np.sin(theta)
    return np.stack([s * np.cos(phi), s * np.sin(phi), np.cos(theta)], axis=-1)


def random_pairs(n, seed=0, below=0.0):
    """(wi, wo) float32 (n, 3): a mix of the configurations that break BRDF code.

    35 % uniform over the hemisphere, 20 % grazing (one or both theta in
    [80, 89.9] deg), 25 % near-mirror (wo = reflect(wi) tilted by 1e-6..1e-1 rad),
    10 % near-retro (wo ~ wi), 10 % near normal (theta < 1 deg).  ``below``
    is the fraction of pairs with one direction under the horizon.
    """
    rng = np.random.default_rng(seed)
    deg = np.pi / 180.0
    theta_i = np.arccos(rng.uniform(0.0, 1.0, n))
    theta_o = np.arccos(rng.uniform(0.0, 1.0, n))
    phi_i = rng.uniform(-np.pi, np.pi, n)
    phi_o = rng.uniform(-np.pi, np.pi, n)
    kind = rng.choice(5, size=n, p=[0.35, 0.2, 0.25, 0.1, 0.1])
    graz = kind == 1
    which = rng.integers(0, 3, n)
    theta_i = np.where(graz & (which != 1), rng.uniform(80 * deg, 89.9 * deg, n), theta_i)
    theta_o = np.where(graz & (which != 0), rng.uniform(80 * deg, 89.9 * deg, n), theta_o)
    normal = kind == 4
    theta_i = np.where(normal, rng.uniform(0, 1 * deg, n), theta_i)
    theta_o = np.where(normal, rng.uniform(0, 1 * deg, n), theta_o)
    theta_i = np.where(kind == 2, np.minimum(theta_i, 89.9 * deg), theta_i)
    wi = _sphere_dir(theta_i, phi_i)
    wo = _sphere_dir(theta_o, phi_o)
    # near-mirror and near-retro: perturb the ideal direction by a tiny tilt
    tilt = np.exp(rng.uniform(np.log(1e-6), np.log(1e-1), n))
    axis = _unit(np.cross(rng.normal(size=(n, 3)), wi))
    mirror = wi * np.array([-1.0, -1.0, 1.0])
    for k, ideal in ((2, mirror), (3, wi)):
        sel = kind == k
        w = np.cos(tilt)[:, None] * ideal + np.sin(tilt)[:, None] * np.cross(axis, ideal)
        w[:, 2] = np.abs(w[:, 2])
        wo = np.where(sel[:, None], _unit(w), wo)
    if below:
        sel = rng.uniform(size=n) < below
        flip = rng.integers(0, 2, n).astype(bool)
        wi[sel & flip, 2] *= -1.0
        wo[sel & ~flip, 2] *= -1.0
    return wi.astype(np.float32), wo.astype(np.float32)


def random_params(spec, n, seed=0, edge=0.05):
    """Per-pair parameters drawn uniformly within the schema bounds; a fraction
    ``edge`` of the items sits exactly at a bound.  float32 {name: (n,) | (n, 3)}."""
    spec = parse_model(spec)
    rng = np.random.default_rng(seed)
    out = {}
    for p in spec.schema():
        shape = (n,) if p.size == 1 else (n, 3)
        value = rng.uniform(p.lower, p.upper, shape)
        at_edge = rng.uniform(size=shape) < edge
        value = np.where(at_edge, np.where(rng.uniform(size=shape) < 0.5, p.lower, p.upper), value)
        out[p.name] = value.astype(np.float32)
    return out


def jax_reference(spec, params, wi, wo, jit=False):
    """brdf.evaluate in float32 on per-pair parameters (vmapped), as numpy.

    Eager by default: under jit, XLA rewrites 1/sqrt(x) into an approximate
    rsqrt, which moves float32 results by an ulp, and ulps matter where GGX
    is ill-conditioned (see model_parity).
    """
    import jax
    import jax.numpy as jnp
    from brdf.model import evaluate
    spec = parse_model(spec)
    p32 = {k: jnp.asarray(v, dtype=jnp.float32) for k, v in params.items()}
    fn = jax.vmap(lambda p, a, b: evaluate(spec, p, a, b))
    if jit:
        fn = jax.jit(fn)
    return np.asarray(fn(p32, jnp.asarray(wi, jnp.float32), jnp.asarray(wo, jnp.float32)))


def compare(gl, ref, big=BIG):
    """Parity numbers of a GPU result against its reference.

    Returns {max_rel (over |ref| > big), max_abs (over the rest), n_big, n,
    worst (flat index of the largest relative difference), nonfinite}.
    """
    gl = np.asarray(gl, dtype=np.float64).ravel()
    ref = np.asarray(ref, dtype=np.float64).ravel()
    nonfinite = int(np.sum(~np.isfinite(gl)) + np.sum(~np.isfinite(ref)))
    diff = np.abs(gl - ref)
    is_big = np.abs(ref) > big
    rel = np.where(is_big, diff / np.where(is_big, np.abs(ref), 1.0), 0.0)
    small = np.where(is_big, 0.0, diff)
    return {"max_rel": float(np.nanmax(rel)) if rel.size else 0.0,
            "max_abs": float(np.nanmax(small)) if small.size else 0.0,
            "n_big": int(is_big.sum()), "n": int(ref.size),
            "worst": int(np.nanargmax(rel)) if rel.size else -1,
            "nonfinite": nonfinite}


def model_parity(spec, n=10_000, seed=0, jit=False):
    """compare() of evaluate_model against jax_reference on random pairs and parameters."""
    wi, wo = random_pairs(n, seed, below=0.02)
    params = random_params(spec, n, seed + 1)
    gl = evaluate_model(spec, params, wi, wo)
    ref = jax_reference(spec, params, wi, wo, jit=jit)
    return compare(gl, ref)


def main(argv=None):
    """Print the parity numbers of every model in brdf.MODEL_EXAMPLES."""
    import argparse
    from brdf.model import MODEL_EXAMPLES
    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("-n", type=int, default=10_000)
    parser.add_argument("--jit", action="store_true", help="also compare with jax.jit-compiled JAX")
    parser.add_argument("models", nargs="*", default=list(MODEL_EXAMPLES))
    args = parser.parse_args(argv)
    import jax
    jax.config.update("jax_enable_x64", True)      # as the tests run; inputs stay float32
    head = f"{'model':34s} {'max rel (>1e-4)':>16s} {'max abs (<=1e-4)':>17s}"
    print(head + (f" {'jit: max rel':>13s} {'max abs':>10s}" if args.jit else ""))
    worst = 0.0
    for model in args.models:
        r = model_parity(model, args.n)
        worst = max(worst, r["max_rel"])
        line = f"{model:34s} {r['max_rel']:16.3e} {r['max_abs']:17.3e}"
        if args.jit:
            j = model_parity(model, args.n, jit=True)
            line += f" {j['max_rel']:13.3e} {j['max_abs']:10.3e}"
        print(line)
    return 0 if worst < REL_TOL else 1


if __name__ == "__main__":
    raise SystemExit(main())
