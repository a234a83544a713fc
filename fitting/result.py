"""FitResult: what a fit produced, saved as versioned JSON."""

import dataclasses
import json
import math
import os
import pathlib

from brdf import __version__, own
from brdf.model import ModelSpec, model_string, parse_model, parameter_schema

from .displayable import ResultDisplay
from .result_file import (MAX_RESULT_BYTES, ResultFileError, check_sizes,  # noqa: F401 -- re-exported
                          read_result_json)

SCHEMA_VERSION = 1
MAX_DEPTH = 32                  # nesting levels (a result uses 4)
BOUND_TOLERANCE = 1e-6          # relative slack on the schema bounds (float32 fits, rounding)
AT_BOUND_FRACTION = 0.01       # a parameter this close (of its range, on its scale) to a bound is flagged


def utc_timestamp() -> str:
    """Now, as an ISO 8601 UTC timestamp to the second: '2026-12-01T16:05:09Z'."""
    import datetime
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


class NotAResultError(ResultFileError):
    """A JSON file that is no fit result at all (not an object, or no spec / parameters),
    e.g. a batch's summary file: a folder scan skips these silently."""


@dataclasses.dataclass(repr=False)
class FitResult(ResultDisplay):
    """One fitted model (shown in notebooks: fitting/displayable.py).

    spec        canonical model string (brdf.parse_model reads it)
    parameters  {name: float or [r, g, b]} in the schema's units and bounds
    errors      {"m1", "m1_per_channel", "loss", "loss_name", "loss_per_channel",
                 "image", "image_per_channel", "image_fixed", "exported_model", "exported_m1",
                 "exported_image", "blender_m1", "blender_image" (fitting.material_errors)}
    optimizer   {"name", "iterations", "evaluations", "seconds", "converged",
                 "starts", "samples", ...}
    provenance  {"file", "sha256", "format", "material"}
    model_file  {"name", "sha256", "path" (as typed; absent in older results)} of the file a model
                of one's own was declared in (brdf/own.py), else None (and absent from the JSON)
    """
    spec: str
    parameters: dict
    errors: dict
    optimizer: dict
    provenance: dict
    toolkit_version: str = __version__
    schema_version: int = SCHEMA_VERSION
    created: str = dataclasses.field(default_factory=lambda: utc_timestamp())
    model_file: dict | None = None

    @property
    def model(self) -> ModelSpec:
        return parse_model(self.spec)

    @property
    def material(self) -> str:
        return self.provenance.get("material") or "material"

    def to_dict(self) -> dict[str, object]:
        """The JSON form: the fields, and ``at_bounds`` (derived, for readers of the file)."""
        data = dict(dataclasses.asdict(self), at_bounds=self.at_bounds())
        if data["model_file"] is None:
            del data["model_file"]
        return data

    def at_bounds(self) -> dict[str, str]:
        """{name: "lower" | "upper"} for parameters within AT_BOUND_FRACTION of their range's
        ends (periodic ones excepted): the fit may want a value outside the range.  The range
        is on the parameter's scale (``Param.position``): of log x for a log-scale one."""
        flags = {}
        for p in parameter_schema(parse_model(self.spec)):
            if getattr(p, "period", None) or p.name not in self.parameters:
                continue
            values = self.parameters[p.name] if isinstance(self.parameters[p.name], list) else [self.parameters[p.name]]
            where = [p.position(min(max(float(v), p.lower), p.upper), math) for v in values]
            if any(t <= AT_BOUND_FRACTION for t in where):
                flags[p.name] = "lower"
            elif any(t >= 1.0 - AT_BOUND_FRACTION for t in where):
                flags[p.name] = "upper"
        return flags

    def to_json(self) -> str:
        """The result as JSON text; ValueError (naming the value) if a number is NaN or infinite."""
        data = self.to_dict()
        bad = first_non_finite(data)
        if bad is not None:
            where, value = bad
            raise ValueError(f"fit result of {_short(self.spec)}: {where} is {_number_name(value)}; "
                             "a fit result holds finite numbers only, refusing to write it")
        try:
            return json.dumps(data, indent=2, sort_keys=False, allow_nan=False)
        except ValueError as err:      # a non-finite number the scan did not reach (custom type)
            raise ValueError(f"fit result of {_short(self.spec)}: {err}") from None

    @classmethod
    def from_dict(cls, data: dict[str, object], source: str = "<dict>") -> "FitResult":
        """A FitResult from its JSON form, validated: THE check of every result read.

        Raises ResultFileError (one line, starting with ``source``) unless
        ``data`` is an object with schema_version == SCHEMA_VERSION, a known
        model ``spec``, exactly that model's ``parameters`` as finite numbers
        (or [r, g, b]) within the schema's bounds, ``errors`` an object of
        finite non-negative numbers (m1, loss, their per-channel lists),
        ``optimizer`` an object and ``provenance`` an object of strings or
        null.  ``optimizer``, ``provenance`` and ``toolkit_version`` may be
        absent (older or hand-written results); no number anywhere may be
        NaN or infinite, and nothing may be nested more than MAX_DEPTH deep.
        """
        def bad(message, kind=ResultFileError):
            return kind(f"{source}: {message}")

        if not isinstance(data, dict):
            raise bad(f"not a fit result (expected a JSON object, found {_kind(data)})", NotAResultError)
        _check_tree(data, bad)
        check_sizes(data, bad)      # no field beyond its cap (result_file.py) before any is used
        if "schema_version" in data:
            version = data["schema_version"]
            if type(version) is not int:
                raise bad(f"schema_version must be the integer {SCHEMA_VERSION}, found {_kind(version)}")
            if version != SCHEMA_VERSION:
                raise bad(f"unsupported result schema_version {_short(version, 40)} "
                          f"(this toolkit reads {SCHEMA_VERSION})")
        if "spec" not in data:
            raise bad("not a fit result (no 'spec': the model string)", NotAResultError)
        if not isinstance(data["spec"], str):
            raise bad(f"'spec' must be a model string, found {_kind(data['spec'])}")
        model_file = data.get("model_file")
        try:
            own.check_result(data["spec"], model_file)     # a model of one's own: registered, or refused
            spec = parse_model(data["spec"])
        except ValueError as err:
            raise bad(str(err)) from None
        if "parameters" not in data:
            raise bad(f"not a fit result (no 'parameters' for {model_string(spec)})", NotAResultError)
        _check_parameters(spec, data["parameters"], bad)
        if "schema_version" not in data:
            raise bad(f"no schema_version (this toolkit reads fit results of schema_version {SCHEMA_VERSION})")
        if "errors" not in data:
            raise bad("fit result lacks 'errors'")
        _check_errors(data["errors"], bad)
        optimizer = data.get("optimizer", {})
        _check_optimizer(optimizer, bad)
        provenance = data.get("provenance", {})
        if not isinstance(provenance, dict):
            raise bad(f"'provenance' must be an object, found {_kind(provenance)}")
        for key, value in provenance.items():
            if value is not None and not isinstance(value, str):
                raise bad(f"provenance {_short(key, 40)!r} must be a string or null, found {_kind(value)}")
        toolkit_version = data.get("toolkit_version", "unknown")
        if not isinstance(toolkit_version, str):
            raise bad(f"'toolkit_version' must be a string, found {_kind(toolkit_version)}")
        created = data.get("created", "")
        if not isinstance(created, str):
            raise bad(f"'created' must be an ISO 8601 UTC timestamp string, found {_kind(created)}")
        return cls(spec=data["spec"], parameters=data["parameters"], errors=data["errors"],
                   optimizer=optimizer, provenance=provenance, toolkit_version=toolkit_version,
                   schema_version=data["schema_version"], created=created, model_file=model_file)

    def save(self, path: str | os.PathLike[str]) -> str | os.PathLike[str]:
        """Write atomically (temporary file + rename) and return the path.

        Raises ValueError (and writes nothing) if a number is NaN or infinite.
        """
        path = pathlib.Path(path)
        text = self.to_json() + "\n"
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, text)
        return path

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> "FitResult":
        """Read and validate a result file (``from_dict``); ResultFileError names the file.

        Files over MAX_RESULT_BYTES, bytes that are not UTF-8 text, invalid
        or too deeply nested JSON, and an object with a key twice are refused
        before any field is looked at.
        """
        path = pathlib.Path(path)
        data = read_result_json(path)
        return cls.from_dict(data, source=str(path))


# --- validation helpers -------------------------------------------------------

def _short(text, limit=60):
    text = str(text)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def _kind(value):
    """What a JSON value is, for messages: 'a number (42)', 'a list', 'null'..."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"{str(value).lower()}"
    if isinstance(value, (int, float)):
        return f"a number ({_short(repr(value), 30)})"
    if isinstance(value, str):
        return f"a string ({_short(repr(value), 30)})"
    if isinstance(value, (list, tuple)):
        return "a list"
    if isinstance(value, dict):
        return "an object"
    return type(value).__name__


def _number_name(value):
    return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")


def _is_number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _finite(value):
    """float(value) if it is a finite number (not a bool), else None."""
    if not _is_number(value):
        return None
    try:
        x = float(value)
    except OverflowError:           # an integer beyond float range
        return None
    return x if math.isfinite(x) else None


def _scan(data, max_depth=None):
    """The first problem in nested dicts / lists, in document order, or None:
    ("non-finite", where, value) for a NaN or infinite float, ("deep", where, None)
    for a container nested more than ``max_depth`` levels.  Iterative, memory
    proportional to the depth (a 16 MiB list is fine)."""
    def children(value):
        items = value.values() if isinstance(value, dict) else value
        if _flat_and_finite(items):        # the common case, checked at C speed
            return iter(())
        return iter(value.items()) if isinstance(value, dict) else enumerate(value)

    def where(keys):
        text = "".join(f"[{k}]" if isinstance(k, int) else f".{_short(k, 40)}" for k in keys)
        return text.lstrip(".") or "the value"

    if isinstance(data, float):
        return ("non-finite", "the value", data) if not math.isfinite(data) else None
    if not isinstance(data, (dict, list, tuple)):
        return None
    stack, keys = [children(data)], []
    while stack:
        try:
            key, value = next(stack[-1])
        except StopIteration:
            stack.pop()
            if keys:
                keys.pop()
            continue
        if isinstance(value, float):
            if not math.isfinite(value):
                return "non-finite", where(keys + [key]), value
        elif isinstance(value, (dict, list, tuple)):
            if max_depth is not None and len(stack) >= max_depth:
                return "deep", where(keys + [key]), None
            stack.append(children(value))
            keys.append(key)
    return None


_SCALARS = frozenset({int, bool, str, type(None)})
_NUMBERS = frozenset({int, bool, float})


def _flat_and_finite(items):
    """True if ``items`` holds only plain scalars and no NaN / infinity (a quick
    test: False just means "look item by item")."""
    types = set(map(type, items))
    if types <= _SCALARS:
        return True
    if float in types and types <= _NUMBERS:
        try:
            return math.isfinite(sum(items, 0.0))    # NaN / inf propagate; an overflow is a false alarm
        except OverflowError:
            return False
    return False


def first_non_finite(data: object) -> tuple[str, object] | None:
    """(where, value) of the first NaN / infinite float in nested dicts and lists, or None.

    ``where`` is a path like ``parameters.albedo[1]``; writers of JSON (results,
    glTF) use it to refuse non-finite numbers with a message that names them.
    """
    found = _scan(data)
    return None if found is None else found[1:]


def _check_tree(data, bad):
    """No nesting deeper than MAX_DEPTH, no NaN or infinite number anywhere."""
    found = _scan(data, MAX_DEPTH)
    if found is None:
        return
    problem, where, value = found
    if problem == "deep":
        raise bad(f"nested more than {MAX_DEPTH} levels deep (at {_short(where, 80)}); not a fit result")
    raise bad(f"{where} is {_number_name(value)}; a fit result holds finite numbers only")


def _check_parameters(spec, params, bad):
    """Exactly the schema's parameters, finite, within bounds (BOUND_TOLERANCE slack)."""
    model = model_string(spec)
    schema = parameter_schema(spec)
    if not isinstance(params, dict):
        raise bad(f"'parameters' must be an object {{name: value}} for {model}, found {_kind(params)}")
    names = [p.name for p in schema]
    extra = [k for k in params if k not in names]
    if extra:
        raise bad(f"unknown parameter {_short(extra[0], 40)!r} for {model} (its parameters: {', '.join(names)})")
    for p in schema:
        if p.name not in params:
            raise bad(f"parameter {p.name!r} of {model} is missing")
        value = params[p.name]
        if p.size == 1:
            values = [value]
            if _finite(value) is None:
                raise bad(f"parameter {p.name!r} of {model} must be a finite number, found {_kind(value)}")
        else:
            values = value if isinstance(value, list) else None
            if values is None or len(values) != 3 or any(_finite(v) is None for v in values):
                found = f"a list of {len(value)}" if isinstance(value, list) else _kind(value)
                raise bad(f"parameter {p.name!r} of {model} must be [r, g, b] (three finite numbers), "
                          f"found {found}")
        slack = BOUND_TOLERANCE * max(1.0, abs(p.lower), abs(p.upper))     # on a log scale relative: x > 0
        low, high = ((p.lower * (1.0 - BOUND_TOLERANCE), p.upper * (1.0 + BOUND_TOLERANCE)) if p.scale == "log"
                     else (p.lower - slack, p.upper + slack))
        for v in values:
            if not low <= float(v) <= high:
                shown = (f"{float(value):.6g}" if p.size == 1
                         else "[" + ", ".join(f"{float(x):.6g}" for x in values) + "]")
                raise bad(f"parameter {p.name!r} of {model} = {shown} is outside its bounds "
                          f"[{p.lower:.6g}, {p.upper:.6g}]")


_ERROR_NUMBERS = ("m1", "loss", "image", "image_fixed", "exported_m1", "exported_image", "blender_m1", "blender_image")
_ERROR_NAMES = ("loss_name", "exported_model")
_ERROR_CHANNELS = ("m1_per_channel", "loss_per_channel", "image_per_channel")


def _check_errors(errors, bad):
    """An object; every number in it (m1, loss, ... and the per-channel lists) finite and >= 0."""
    if not isinstance(errors, dict):
        raise bad(f"'errors' must be an object (m1, loss, ...), found {_kind(errors)}")
    for key, value in errors.items():
        name = _short(key, 40)
        if key in _ERROR_NAMES:
            if not isinstance(value, str):
                raise bad(f"errors {key!r} must be a string, found {_kind(value)}")
        elif key in _ERROR_CHANNELS or isinstance(value, list):
            if not isinstance(value, list) or not all(_is_number(v) for v in value):
                raise bad(f"errors {name!r} must be a list of numbers, found {_kind(value)}")
            if key in _ERROR_CHANNELS and len(value) != 3:
                raise bad(f"errors {name!r} must hold 3 numbers (R, G, B), found {len(value)}")
            if any(_finite(v) is None or v < 0 for v in value):
                raise bad(f"errors {name!r} must hold finite non-negative numbers")
        elif key in _ERROR_NUMBERS or _is_number(value):
            x = _finite(value)
            if x is None or x < 0:
                raise bad(f"errors {name!r} must be a finite non-negative number, found {_kind(value)}")


_OPTIMIZER_COUNTS = ("iterations", "evaluations", "starts", "samples", "samples_full")
_OPTIMIZER_SECONDS = ("seconds", "seconds_total")


def _check_optimizer(optimizer, bad):
    """An object; the fields the toolkit reads have their types (others are kept as they are)."""
    if not isinstance(optimizer, dict):
        raise bad(f"'optimizer' must be an object, found {_kind(optimizer)}")
    for key in _OPTIMIZER_COUNTS + _OPTIMIZER_SECONDS:
        if key in optimizer:
            x = _finite(optimizer[key])
            if x is None or x < 0:
                raise bad(f"optimizer {key!r} must be a non-negative number, found {_kind(optimizer[key])}")
    if "max_theta" in optimizer:
        x = _finite(optimizer["max_theta"])
        if x is None or x <= 0:
            raise bad(f"optimizer 'max_theta' must be a positive angle in degrees, "
                      f"found {_kind(optimizer['max_theta'])}")
    if "name" in optimizer and not isinstance(optimizer["name"], str):
        raise bad(f"optimizer 'name' must be a string, found {_kind(optimizer['name'])}")
    if "converged" in optimizer and not isinstance(optimizer["converged"], bool):
        raise bad(f"optimizer 'converged' must be true or false, found {_kind(optimizer['converged'])}")


def atomic_write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write text to path atomically (data_loaders' one atomic writer)."""
    from data_loaders.measured import write_file_atomic
    write_file_atomic(path, text)
