"""``jax`` and ``jax.numpy`` for the formulas of brdf, imported on first use.

Each term's declaration (brdf/declare.py) sits beside its formula, so reading
the declarations -- the model strings, the schema, ``brdf-fit models`` and
``brdf-fit schema`` -- imports every formula module.  Those modules take
``jnp`` (and brdf/model.py ``jax``) from here, so importing brdf imports no
JAX (over a second); the first attribute a formula reads (``jnp.clip``)
imports the real module and every read returns the real module's attribute:
the formulas call the same JAX functions as before and compute the same
numbers.

jaxtyping's ``Array`` and ``ArrayLike`` import JAX as well, so the modules of
brdf postpone their annotations (``from __future__ import annotations``) and
import those two names for type checkers only.
"""

import importlib
import types


class LazyModule(types.ModuleType):
    """Stands for the module ``name``, imported when one of its attributes is first read."""

    def __getattr__(self, attribute):     # called only for names the stand-in lacks: all but __name__ & co.
        return getattr(importlib.import_module(self.__name__), attribute)


jax = LazyModule("jax")
jnp = LazyModule("jax.numpy")
