"""Every public function and method of brdf, fitting and data_loaders is annotated.

Public: the names in a module's ``__all__`` if it has one, else the names it
defines without a leading underscore; for a class, its methods, properties,
class and static methods without a leading underscore, and its ``__init__``
(unless a dataclass or NamedTuple generates it).  Modules whose name starts
with an underscore are private.  Every parameter (but ``self`` / ``cls``) and
the return must carry an annotation: arrays as jaxtyping shapes
(``Float[Array, "*batch 3"]``, ``Float[np.ndarray, "n 3"]``), the rest as
plain types.

data_loaders annotates with jaxtyping's wrappers over numpy only (see
data_loaders/_typing.py): importing it must still not import JAX.
"""

import importlib
import inspect
import pkgutil
import subprocess
import sys

import pytest

PACKAGES = ("brdf", "fitting", "data_loaders")

# The command line (argparse handlers, checked by the CLI tests) is not covered.
SKIPPED_MODULES = {"brdf_fit.cli", "brdf_fit.commands"}

# Deliberate exceptions, "module.qualname": why.
EXCEPTIONS = {
}


def _modules():
    names = []
    for package in PACKAGES:
        names.append(package)
        for info in pkgutil.walk_packages(importlib.import_module(package).__path__, package + "."):
            if not info.name.rsplit(".", 1)[1].startswith("_") and info.name not in SKIPPED_MODULES:
                names.append(info.name)
    return names


def _methods(cls):
    generated_init = hasattr(cls, "__dataclass_fields__") or hasattr(cls, "_fields")
    for name, value in vars(cls).items():
        if name.startswith("_") and not (name == "__init__" and not generated_init):
            continue
        if isinstance(value, (staticmethod, classmethod)):
            value = value.__func__
        elif isinstance(value, property):
            value = value.fget
        if inspect.isfunction(value):
            yield f"{cls.__name__}.{name}", value


def public_callables(module_name):
    """(qualified name, function) of the public functions and methods of a module."""
    module = importlib.import_module(module_name)
    names = getattr(module, "__all__", None)
    if names is None:
        names = [n for n in vars(module) if not n.startswith("_")]
    for name in names:
        obj = getattr(module, name)
        if getattr(obj, "__module__", None) != module_name:
            continue                        # re-exported: checked where it is defined
        if inspect.isfunction(obj):
            yield f"{module_name}.{name}", obj
        elif inspect.isclass(obj):
            for qualname, method in _methods(obj):
                yield f"{module_name}.{qualname}", method


def missing_annotations(function):
    """Names of the unannotated parameters of ``function``, and "return" if its return is."""
    signature = inspect.signature(function)
    missing = [p.name for p in signature.parameters.values()
               if p.name not in ("self", "cls") and p.annotation is inspect.Parameter.empty]
    if signature.return_annotation is inspect.Signature.empty:
        missing.append("return")
    return missing


@pytest.mark.parametrize("module_name", _modules())
def test_public_functions_are_annotated(module_name):
    unannotated = {name: missing for name, function in public_callables(module_name)
                   if name not in EXCEPTIONS and (missing := missing_annotations(function))}
    assert not unannotated, f"public functions without annotations (parameters, or return): {unannotated}"


def test_the_check_sees_a_missing_annotation():
    def partly(x: int, y, *, z: float = 1.0):
        return x

    assert missing_annotations(partly) == ["y", "return"]
    assert list(public_callables("brdf.geometry"))     # the walk finds functions at all
    assert any(name == "data_loaders.measured.MeasuredBRDF.lookup"
               for name, _ in public_callables("data_loaders.measured"))


def test_exceptions_still_exist():
    known = {name for module in _modules() for name, _ in public_callables(module)}
    assert set(EXCEPTIONS) <= known, f"stale entries in EXCEPTIONS: {set(EXCEPTIONS) - known}"


def test_data_loaders_annotations_import_no_jax():
    code = "import sys, data_loaders; print('jax' in sys.modules, 'jaxtyping' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "True"], "data_loaders must annotate with jaxtyping over numpy without importing JAX"


def test_brdf_imports_no_jax_until_a_formula_runs():
    """brdf postpones its annotations (jaxtyping's Array imports JAX) and takes jax.numpy
    from brdf/_lazy.py: its declarations read without JAX, a formula imports it."""
    names = [name for name in _modules() if name.split(".")[0] == "brdf"]
    code = (f"import importlib, sys\nfor name in {names!r}:\n    importlib.import_module(name)\n"
            "print('jax' in sys.modules)\nimport brdf, numpy as np\n"
            "f = brdf.evaluate('ggx+lambert', brdf.default_params(brdf.parse_model('ggx+lambert')), "
            "np.array([[0.0, 0.6, 0.8]]), np.array([[0.0, -0.6, 0.8]]))\n"
            "print('jax' in sys.modules)\nimport jax\nprint(isinstance(f, jax.Array))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "True", "True"], out
