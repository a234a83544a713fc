"""Batch execution: many measured files x many models, resumable, local or on Dask.

``run.run_batch`` is the entry point; ``task`` is the work on one input,
``folder`` the output folder's names, ``executors`` where the tasks run.
"""
