"""Many fit results as one pandas DataFrame (pandas: the optional ``notebook`` extra).

Columns, in order (a row per fit, in the order the results were given;
folders in file-name order):

    material, model, m1, image, exported_model, exported_m1, exported_image,
    loss_name, loss, seconds, converged, at_bounds, file, created,
    then one column per parameter: its name, or NAME_r / NAME_g / NAME_b
    for a colour (models without a parameter have NaN there).

``m1``, ``image``, ``loss`` and the ``exported_*`` values are the result's
``errors`` entries; ``seconds`` is the whole fit (``optimizer.seconds_total``,
else ``optimizer.seconds``); ``at_bounds`` names the parameters within 1 %
of an end of their range ("roughness:lower"); ``file`` is the result file
(None for an object).  Missing values are NaN / None.
"""

import pathlib
import warnings

COLUMNS = ("material", "model", "m1", "image", "exported_model", "exported_m1", "exported_image",
           "loss_name", "loss", "seconds", "converged", "at_bounds", "file", "created")
CHANNELS = ("r", "g", "b")


def _items(items):
    if isinstance(items, (str, pathlib.PurePath)) or not hasattr(items, "__iter__"):
        return [items]
    return list(items)


def collect(items) -> list[tuple[str | None, object]]:
    """[(file or None, FitResult)] from results, result files and folders of them.

    A file given by name must be a fit result (ResultFileError propagates);
    in a folder, JSON files that are no fit result (a batch's summaries) are
    skipped and broken results skipped with a warning.
    """
    from fitting.result import FitResult, NotAResultError, ResultFileError
    out = []
    for item in _items(items):
        if isinstance(item, FitResult):
            out.append((None, item))
            continue
        path = pathlib.Path(item)
        if path.is_dir():
            for q in sorted(path.glob("*.json")):
                try:
                    out.append((str(q), FitResult.load(q)))
                except NotAResultError:
                    continue
                except ResultFileError as err:
                    warnings.warn(f"{err} (skipped)", stacklevel=3)
        elif path.exists():
            out.append((str(path), FitResult.load(path)))
        else:
            raise FileNotFoundError(f"{path}: no such result file or folder")
    return out


def row(result, file=None) -> dict[str, object]:
    """One result's row (the module's columns)."""
    nan = float("nan")
    e, o = result.errors or {}, result.optimizer or {}
    out = {"material": result.material, "model": result.spec}
    for key in ("m1", "image"):
        out[key] = float(e[key]) if key in e else nan
    out["exported_model"] = e.get("exported_model")
    for key in ("exported_m1", "exported_image"):
        out[key] = float(e[key]) if key in e else nan
    out["loss_name"] = e.get("loss_name")
    out["loss"] = float(e["loss"]) if "loss" in e else nan
    seconds = o.get("seconds_total", o.get("seconds"))
    out["seconds"] = float(seconds) if seconds is not None else nan
    out["converged"] = o.get("converged")
    out["at_bounds"] = ", ".join(f"{k}:{v}" for k, v in result.at_bounds().items())
    out["file"] = file
    out["created"] = result.created
    for name, value in result.parameters.items():
        if isinstance(value, list):
            out.update({f"{name}_{c}": float(v) for c, v in zip(CHANNELS, value)})
        else:
            out[name] = float(value)
    return out


def results_table(items):
    """A pandas DataFrame of fit results (FitResult objects, result files, batch
    folders, or an iterable of them): one row per fit, the module's columns."""
    try:
        import pandas as pd
    except ImportError:
        raise ImportError("results_table needs pandas: pip install 'brdf-fit[notebook]' (or pandas)") from None
    rows = [row(r, f) for f, r in collect(items)]
    params = list(dict.fromkeys(k for r in rows for k in r if k not in COLUMNS))
    return pd.DataFrame(rows, columns=list(COLUMNS) + params)
