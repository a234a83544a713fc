"""FitResult: what a fit produced, saved as versioned JSON."""

import dataclasses
import json
import os
import pathlib
import tempfile

from brdf import __version__
from brdf.model import parse_model, parameter_schema

SCHEMA_VERSION = 1


class ResultFileError(ValueError):
    """A result JSON that cannot be read (names the file and the problem)."""


@dataclasses.dataclass
class FitResult:
    """One fitted model.

    spec        canonical model string (brdf.parse_model reads it)
    parameters  {name: float or [r, g, b]} in the schema's units and bounds
    errors      {"m1", "m1_per_channel", "loss", "loss_name", "loss_per_channel"}
    optimizer   {"name", "iterations", "evaluations", "seconds", "converged",
                 "starts", "samples", ...}
    provenance  {"file", "sha256", "format", "material"}
    """
    spec: str
    parameters: dict
    errors: dict
    optimizer: dict
    provenance: dict
    toolkit_version: str = __version__
    schema_version: int = SCHEMA_VERSION

    @property
    def model(self):
        return parse_model(self.spec)

    @property
    def material(self):
        return self.provenance.get("material") or "material"

    def to_dict(self):
        return dataclasses.asdict(self)

    def to_json(self):
        return json.dumps(self.to_dict(), indent=2, sort_keys=False)

    @classmethod
    def from_dict(cls, data, source="<dict>"):
        if not isinstance(data, dict):
            raise ResultFileError(f"{source}: not a fit result (expected a JSON object)")
        version = data.get("schema_version")
        if version != SCHEMA_VERSION:
            raise ResultFileError(f"{source}: unsupported result schema_version {version!r} "
                                  f"(this toolkit reads {SCHEMA_VERSION})")
        fields = [f.name for f in dataclasses.fields(cls)]
        missing = [f for f in fields if f not in data]
        if missing:
            raise ResultFileError(f"{source}: fit result lacks {', '.join(missing)}")
        try:
            spec = parse_model(data["spec"])
        except ValueError as err:
            raise ResultFileError(f"{source}: {err}") from None
        names = {p.name: p.size for p in parameter_schema(spec)}
        params = data["parameters"]
        for name, size in names.items():
            value = params.get(name) if isinstance(params, dict) else None
            ok = (isinstance(value, (int, float)) if size == 1 else
                  isinstance(value, list) and len(value) == 3
                  and all(isinstance(v, (int, float)) for v in value))
            if not ok:
                raise ResultFileError(f"{source}: parameter {name!r} missing or malformed "
                                      f"(expected {'a number' if size == 1 else '[r, g, b]'})")
        return cls(**{f: data[f] for f in fields})

    def save(self, path):
        """Write atomically (temporary file + rename) and return the path."""
        path = pathlib.Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(path, self.to_json() + "\n")
        return path

    @classmethod
    def load(cls, path):
        path = pathlib.Path(path)
        try:
            text = path.read_text()
        except OSError as err:
            raise ResultFileError(f"{path}: cannot read ({err.strerror})") from None
        try:
            data = json.loads(text)
        except json.JSONDecodeError as err:
            raise ResultFileError(f"{path}: not valid JSON ({err.msg}, line {err.lineno})") from None
        return cls.from_dict(data, source=str(path))


def atomic_write_text(path, text):
    """Write text to path through a temporary file in the same folder and a rename."""
    path = pathlib.Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
