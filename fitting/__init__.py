"""Fitting brdf models to measured data: losses, optimizers, results, command line.

Importing this package imports nothing heavy (no JAX), so ``brdf-fit`` can
install its Ctrl-C handling first.  The fitter works in float64 and keeps
compiled XLA programs on disk: the fitting modules that use JAX (``fit``,
``fused``, ``losses``, ``synthetic``, ``transforms``) apply those settings
when they are imported (see ``fitting/_jax.py``; ``BRDF_JAX_CACHE=off`` turns
the compilation cache off).
"""
