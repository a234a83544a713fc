"""Traced programs kept on disk (fitting/stored.py): the same numbers, read back instead of traced,
never the program of other code or settings, and only a speed-up when the folder fails."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from brdf import parse_model
from fitting import fused, image_error, stored
from fitting.fit import image_targets, prepare
from fitting.objective import HybridSet
from fitting.synthetic import synthetic_measured
from fitting.transforms import vector_size


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("BRDF_JAX_CACHE", str(tmp_path))
    return tmp_path / "programs"


def _counted():
    """A function and the number of times it was traced."""
    calls = []

    def fn(x, d):
        calls.append(1)
        return jnp.sum(jnp.sin(x) * d["a"]), {"g": x * d["a"]}
    return fn, calls


ARGS = (np.linspace(0.0, 1.0, 7), {"a": np.arange(7.0)})


def _same(a, b):
    return all(np.array_equal(x, y) for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b)))


def test_a_second_program_reads_the_first_ones_file_instead_of_tracing(cache):
    fn, calls = _counted()
    first = stored.stored_jit(fn, "test sin")(*ARGS)
    assert len(calls) == 1 and len(list(cache.glob("*.jaxexport"))) == 1
    fn2, calls2 = _counted()                # a fresh process's program: a new function, the same name
    second = stored.stored_jit(fn2, "test sin")(*ARGS)
    assert calls2 == [] and _same(first, second)
    assert _same(first, jax.jit(fn)(*ARGS))


def test_another_name_shape_setting_or_source_is_another_program(cache, monkeypatch):
    fn, calls = _counted()
    stored.stored_jit(fn, "test sin")(*ARGS)
    stored.stored_jit(fn, "test sin, another static argument")(*ARGS)
    stored.stored_jit(fn, "test sin")(np.zeros(3), {"a": np.ones(3)})
    stored.stored_jit(fn, "test sin")(np.zeros(7, np.float32), {"a": np.ones(7, np.float32)})
    monkeypatch.setitem(stored.SETTINGS, "test setting", lambda: "on")
    stored.stored_jit(fn, "test sin")(*ARGS)
    assert len(calls) == 5 and len(list(cache.glob("*.jaxexport"))) == 5
    # other sources: their programs are never read, and the first write removes them
    monkeypatch.setattr(stored, "source_key", lambda: "another-source")
    monkeypatch.setattr(stored, "_pruned", False)
    stored.stored_jit(fn, "test sin")(*ARGS)
    assert len(calls) == 6
    assert [p.name.startswith("another-source") for p in cache.glob("*.jaxexport")] == [True]


def test_the_source_key_hashes_every_module_of_brdf_and_fitting():
    import hashlib
    import pathlib

    import jaxlib
    root = pathlib.Path(stored.__file__).resolve().parent.parent
    digest = hashlib.sha256(f"jax {jax.__version__} jaxlib {jaxlib.__version__}".encode())
    for package in ("brdf", "fitting"):
        for path in sorted((root / package).rglob("*.py")):
            digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    assert stored.source_key() == digest.hexdigest()[:24]


def test_a_program_is_lowered_once_for_the_outputs_of_another_numpy_arrays_or_shapes(cache):
    """A stored program's outputs are committed arrays (``exported.call`` places them): fed to
    another stored program beside numpy arrays (a parameter held at its neutral value), or after
    the shapes a compilation ahead lowers for, it is the same program, lowered and compiled once."""
    lowered = []

    def listener(event, duration, **kwargs):
        if event == "/jax/core/compile/jaxpr_to_mlir_module_duration":     # JAX's event of a lowering
            lowered.append(event)
    make = stored.stored_jit(lambda x: x * 2.0, "test make")
    use = stored.stored_jit(lambda x, y: jnp.sum(jnp.sin(x) * y), "test use")
    x, y = np.linspace(0.0, 1.0, 5), np.arange(5.0)
    made = make(x)
    jax.monitoring.register_event_duration_secs_listener(listener)
    try:
        use.lower(*[jax.ShapeDtypeStruct(a.shape, a.dtype) for a in (x, y)]).compile()     # ahead, from shapes
        n = len(lowered)
        values = [use(2.0 * x, y), use(made, y), use(y, made), use(made, made)]
    finally:
        jax.monitoring.unregister_event_duration_listener(listener)
    assert n >= 1 and len(lowered) == n
    expected = [np.sum(np.sin(2.0 * x) * y), np.sum(np.sin(2.0 * x) * y), np.sum(np.sin(y) * 2.0 * x),
                np.sum(np.sin(2.0 * x) * 2.0 * x)]
    assert np.allclose([float(v) for v in values], expected, rtol=1e-12)


@pytest.mark.parametrize("damage", [b"", b"not a program", "half", "another program"])
def test_an_unreadable_file_is_traced_again_and_replaced(cache, damage):
    fn, calls = _counted()
    other = stored.stored_jit(fn, "test sin")(np.zeros(3), {"a": np.ones(3)})
    (other_path,) = cache.glob("*.jaxexport")
    expected = stored.stored_jit(fn, "test sin")(*ARGS)
    path, = set(cache.glob("*.jaxexport")) - {other_path}
    good = path.read_bytes()
    path.write_bytes({"half": good[: len(good) // 2], "another program": other_path.read_bytes()}.get(damage, damage))
    again = stored.stored_jit(fn, "test sin")(*ARGS)
    assert len(calls) == 3 and _same(expected, again) and not _same(other, again)
    assert path.read_bytes() == good


def test_no_folder_or_an_unwritable_one_traces_as_jit(tmp_path, monkeypatch):
    fn, _ = _counted()
    monkeypatch.setenv("BRDF_JAX_CACHE", "off")
    assert _same(stored.stored_jit(fn, "test sin")(*ARGS), jax.jit(fn)(*ARGS))
    blocker = tmp_path / "a file"
    blocker.write_text("")
    monkeypatch.setenv("BRDF_JAX_CACHE", str(blocker))     # the folder cannot be made
    assert _same(stored.stored_jit(fn, "test sin")(*ARGS), jax.jit(fn)(*ARGS))
    assert not list(tmp_path.rglob("*.jaxexport"))


@pytest.mark.parametrize("model", ["ggx+lambert+f90", "ggx+cod_wwii+ms+clearcoat", "gltf+specular+clearcoat"])
def test_a_stored_hybrid_loss_and_gradient_equals_the_traced_one_bit_for_bit(cache, monkeypatch, model):
    truth = {"albedo": [0.3, 0.2, 0.1], "roughness": 0.3, "f0": [0.05, 0.06, 0.07]}
    measured = synthetic_measured("ggx+burley", truth, grid=(30, 30, 60, 1), noise=0.05, seed=3)
    data = HybridSet(prepare(measured, samples=5_000)[1], image_targets(measured).fit, np.asarray(0.5))
    spec = parse_model(model)
    u = np.random.default_rng(1).normal(size=vector_size(spec))
    with jax.enable_x64(True):
        exported = fused.value_and_grad(spec, hybrid=True)(u, data)        # traced, written
        assert len(list(cache.glob("*.jaxexport"))) == 1
        monkeypatch.setattr(jax.export, "export", None)                     # read back: never traced
        read = fused.value_and_grad(spec, hybrid=True)(u, data)
        monkeypatch.setenv("BRDF_JAX_CACHE", "off")
        traced = fused.value_and_grad(spec, hybrid=True)(u, data)           # plain jit
    assert _same(exported, read) and _same(read, traced)


def test_the_image_difference_is_a_setting_of_every_key(monkeypatch):
    before = stored._settings()
    monkeypatch.setattr(image_error, "DIFFERENCE", "srgb")
    assert stored._settings() != before and "'srgb'" in stored._settings()
