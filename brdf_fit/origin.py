"""Whether the libraries ``brdf-fit`` imports are this distribution's.

The distribution installs five top-level packages: ``brdf_fit`` and the libraries
``brdf``, ``fitting``, ``data_loaders`` and ``shaders`` (the layout the project was
asked for; docs/packaging.md says why the names stay).  Those four names are generic:
a ``fitting.py`` in the working directory (``python -m brdf_fit`` puts it first on
``sys.path``) or a folder on ``PYTHONPATH`` is imported instead, and the command
would fail later with an import error or a traceback that names neither file.
``shadowed()`` says so in one line before anything of them is imported.

It reads only import specs (``importlib.util.find_spec`` of a top-level name imports
nothing), so the check costs well under a millisecond and changes nothing global.
"""

import importlib.util
import pathlib

LIBRARIES = ("brdf", "fitting", "data_loaders", "shaders")


def _here(name: str) -> pathlib.Path:
    """Where this distribution's package ``name`` is: beside ``brdf_fit``, in site-packages
    for a wheel, in the checkout for an editable install."""
    return pathlib.Path(__file__).resolve().parent.parent / name


def shadowed() -> str | None:
    """One line naming the first library that would be imported from elsewhere than this
    distribution, the file that shadows it and where the right one is; None when all are ours."""
    for name in LIBRARIES:
        spec = importlib.util.find_spec(name)
        expected = _here(name)
        origin = pathlib.Path(spec.origin).resolve() if spec is not None and spec.origin else None
        if origin is not None and origin.parent == expected.resolve():
            continue
        if spec is None:
            return f"the package {name!r} of brdf-fit is missing (expected at {expected}); reinstall brdf-fit"
        where = origin or ", ".join(str(p) for p in (spec.submodule_search_locations or [])) or "?"
        return (f"the package {name!r} is imported from {where}, which shadows brdf-fit's {expected}: "
                "rename that file or folder, or take its directory off PYTHONPATH / the working directory")
    return None


__all__ = ["shadowed", "LIBRARIES"]
