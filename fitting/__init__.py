"""Fitting brdf models to measured data: losses, optimizers, results, command line.

The fitter works in float64 (M1 differences between models are in the 4th
digit; float32 sums over 10^5-10^6 samples blur them), so importing this
package enables JAX's 64-bit mode.
"""

import jax

jax.config.update("jax_enable_x64", True)
