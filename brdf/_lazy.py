"""``jax`` and ``jax.numpy`` for the formulas of brdf, imported on first use.

Each term's declaration (brdf/declare.py) sits beside its formula, so reading
the declarations -- the model strings, the schema, ``brdf-fit models`` and
``brdf-fit schema`` -- imports every formula module.  Those modules take
``jnp`` (and brdf/model.py ``jax``) from here, so importing brdf imports no
JAX (over a second); the first attribute a formula reads (``jnp.clip``)
imports the real module and copies its attributes onto the stand-in, so
later reads are plain attribute reads (as fast as the module's own) of the
real module's objects: the formulas call the same JAX functions as before and
compute the same numbers.

jaxtyping's ``Array`` and ``ArrayLike`` import JAX as well, so the modules of
brdf postpone their annotations (``from __future__ import annotations``) and
import those two names for type checkers only.
"""

import importlib
import types


class LazyModule(types.ModuleType):
    """Stands for the module ``name``, imported when one of its attributes is first read."""

    def __getattr__(self, attribute):     # called only for names the stand-in lacks: all, at first
        module = importlib.import_module(self.__name__)
        self.__dict__.update(module.__dict__)
        return getattr(module, attribute)


jax = LazyModule("jax")
jnp = LazyModule("jax.numpy")
