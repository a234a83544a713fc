"""The annotation vocabulary of data_loaders: jaxtyping's dtype/shape wrappers over numpy.

``import jaxtyping`` and ``Float[np.ndarray, "n 3"]`` import no JAX, but
``jaxtyping.Array`` / ``jaxtyping.ArrayLike`` do (lazily), and data_loaders
imports no JAX; so array-like inputs are ``Float[ArrayLike, "m 3"]`` with
numpy's ``ArrayLike``, and arrays returned are ``Float[np.ndarray, "n 3"]``.
"""

from jaxtyping import Bool, Float, Int
from numpy.typing import ArrayLike

__all__ = ["ArrayLike", "Bool", "Float", "Int"]
