"""A model of your own: declared in your Python file, fitted like any other (docs/models.md).

    from brdf.own import OwnModel, Param, Start

    def evaluate(p, wi, wo):          # JAX: (..., 3) directions -> (..., 3) RGB BRDF in 1/sr, no cosine
        ...

    MY_MODEL = OwnModel("my_model", (Param("albedo", 3, 0.0, 1.0, 0.5, "diffuse albedo"), ...), evaluate)

``brdf-fit fit TABLE --model my_file.py:MY_MODEL`` (or ``load_file("my_file.py",
"MY_MODEL")`` in Python) imports the file -- because the user named it, never
because a data or result file names it -- and registers the model under the
model string ``own:my_model``.  In Python, ``fitting.fit(measured, MY_MODEL)``
takes the object itself (registered on the way).

``glsl=`` (optional) is the same BRDF in GLSL, which the preview renderer draws (the
report's lit spheres, ``brdf-fit render`` / ``view``): source text defining

    vec3 own_brdf(BrdfParams p, vec3 wi, vec3 wo)

(``GLSL_FUNCTION``) that returns the RGB BRDF in 1/sr without the cosine, as ``evaluate``
does, at one direction pair: unit vectors in the same local frame (normal +z); pairs below
the horizon never reach it (the toolkit returns 0 for them, as in JAX).  ``BrdfParams`` is
generated from ``params`` as for every model (shaders/library.py): one member per
parameter, of its name, ``float`` for size 1 and ``vec3`` for size 3 (a name that is a
GLSL keyword gets a trailing ``_``; one GLSL cannot hold is refused with glsl=).  The
source is compiled after the GLSL library, so it may call its constants and terms
(``PI``, ``INV_PI``, ``dot3``, ``half_vector``, ``log_cosine``, ``ggx_ndf``, ...) and
must not define their names again; it must compile as GLSL 3.30 and 4.30 (no
``#version``, no ``#include``).  A compile error is an OwnModelError naming the model,
its file and the line of ``glsl`` (shaders/own_glsl.py).  Without ``glsl`` the renderer
refuses the model, saying it does not draw it.

A ModelSpec of an own model holds the OwnModel object (its ``own`` field):
compared and hashed by identity, so a jitted program is never shared by two
models of one name (a file changed and loaded again in one process).  Its
programs are traced in every process, never stored on disk (fitting/stored.py:
``NOT_STORED``), as the toolkit's sources do not say what the user's file computes.

A result file of a model loaded from a file records the file's name and
sha256 (``source``) and the path the user gave it by (``path``, as typed: for
the reader's information); reading it back needs the same file registered
first (``check_source``): one error naming the file, and a changed file is
refused.  The sha256 identifies the file; a name or path read from a result is
data, quoted in a message (``_as_data``), never imported nor suggested.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import math
import numbers
import os
import pathlib
import re
import typing

from .declare import LINEAR, LOG, GltfRule, Param, Start, Term
from .own_guard import (CHECK_PAIRS, OwnModelError, guarded_evaluate, guarded_rule, import_deadline,  # noqa: F401
                        label, no_hard_exit, user_code)

__all__ = ["OwnModel", "Param", "Start", "OwnModelError", "load_file", "load_bytes", "register", "lookup", "PREFIX",
           "GLSL_FUNCTION", "GLSL_SIGNATURE"]

PREFIX = "own:"                 # the model string of an own model: own:NAME
NOT_STORED = "<own model: traced, never stored>"   # in a program's name: not kept on disk (fitting/stored.py)
_NAME = re.compile(r"^[a-z][a-z0-9_]{0,47}$")
GLSL_FUNCTION = "own_brdf"      # the function glsl= defines (shaders/model.glsl calls it)
GLSL_SIGNATURE = f"vec3 {GLSL_FUNCTION}(BrdfParams p, vec3 wi, vec3 wo)"
MAX_BOUND = 1e30                # a parameter's bounds within +-MAX_BOUND (the box's width, squares of values)
_GLSL_DEFINES = re.compile(rf"\b{GLSL_FUNCTION}\s*\(")
_GLSL_MEMBER = re.compile(r"^(?!gl_)(?!.*__)[A-Za-z][A-Za-z0-9_]*$")   # a name BrdfParams can hold


@dataclasses.dataclass(frozen=True, eq=False)
class OwnModel:
    """A model declared in the user's own file.

    name        its model string is ``own:NAME`` (lower case letters, digits, _)
    params      Params (brdf.declare.Param: name, size 1 or 3, lower, upper,
                default, description; ``start=Start(scan=(...))`` adds start
                candidates, ``Start(rule=lambda e: e.albedo)`` starts from the data;
                ``scale="log"`` fits a wide positive range on log(x))
    evaluate    JAX function f(params, wi, wo) -> (..., 3): the BRDF in 1/sr without
                the cosine; ``params`` maps each name to an array of shape () or (3,),
                wi and wo are (..., 3) unit vectors, normal +z (pairs below the horizon
                are set to 0 by the toolkit).  Differentiated by jax.grad.
    glsl        optional GLSL source of the same function: it defines GLSL_SIGNATURE
                (the module docstring); the preview renderer draws the model with it
    description a line for listings
    source      (file name, sha256) when loaded from a file (``load_file``), else None
    path        the path the file was given by, as the user typed it (not resolved), else None
    reciprocal  f(wi, wo) = f(wo, wi)?  None (the usual): found when the file is loaded
                (``check``: evaluate at its defaults and bounds on pairs of unequal angles, both
                ways); False: the fit evaluates each pair in both orientations, as for a
                layer weighed at n.v; True: declared (the check refuses it where it is not)
                -- a model declared in Python and never checked counts as not reciprocal
    Compared and hashed by identity (a jit static argument through ModelSpec).
    """
    name: str
    params: tuple
    evaluate: typing.Callable
    glsl: typing.Optional[str] = None
    description: str = ""
    source: typing.Optional[tuple] = None
    path: typing.Optional[str] = None
    reciprocal: typing.Optional[bool] = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise OwnModelError(f"own model name {self.name!r}: use lower case letters, digits and _ "
                                "(a letter first, at most 48)")
        object.__setattr__(self, "params", tuple(self.params))
        names = set()
        for p in self.params:
            if not isinstance(p, Param):
                raise OwnModelError(f"own model {self.name}: params must be brdf.own.Param, found {type(p).__name__}")
            if not all(_finite(x) for x in (p.lower, p.upper, p.default)):
                raise OwnModelError(f"own model {self.name}: parameter {p.name!r} needs finite numbers for its "
                                    f"bounds and default, found [{p.lower!r}, {p.upper!r}] and {p.default!r}")
            if max(abs(p.lower), abs(p.upper)) > MAX_BOUND:
                raise OwnModelError(f"own model {self.name}: parameter {p.name!r} has bounds [{p.lower:g}, "
                                    f"{p.upper:g}] beyond +-{MAX_BOUND:g}: the fit's arithmetic overflows there; "
                                    "rescale the parameter in the formula")
            if p.size not in (1, 3) or not p.lower < p.upper or not p.lower <= p.default <= p.upper:
                raise OwnModelError(f"own model {self.name}: parameter {p.name!r} needs size 1 or 3 and "
                                    f"lower < upper with the default between them")
            if p.scale not in (LINEAR, LOG) or (p.scale == LOG and (p.lower <= 0 or p.period)):
                raise OwnModelError(f"own model {self.name}: parameter {p.name!r}: scale={p.scale!r} must be "
                                    f"{LINEAR!r} or {LOG!r}, and {LOG!r} needs a positive lower bound "
                                    f"(found [{p.lower:g}, {p.upper:g}]) and no period")
            scan = tuple(getattr(p.start, "scan", ()) or ())
            if not all(_finite(v) and p.lower <= float(v) <= p.upper for v in scan):
                raise OwnModelError(f"own model {self.name}: parameter {p.name!r}: Start(scan={scan!r}) needs "
                                    f"finite values within its bounds [{p.lower:g}, {p.upper:g}]")
            if p.name in names:
                raise OwnModelError(f"own model {self.name}: parameter {p.name!r} declared twice")
            names.add(p.name)
        if not self.params:
            raise OwnModelError(f"own model {self.name}: no parameters to fit")
        if self.reciprocal not in (None, True, False):
            raise OwnModelError(f"own model {self.name}: reciprocal must be True, False or left out "
                                f"(found by the toolkit), not {self.reciprocal!r}")
        if not callable(self.evaluate):
            raise OwnModelError(f"own model {self.name}: evaluate must be a function f(params, wi, wo)")
        if self.glsl is not None:
            if not (isinstance(self.glsl, str) and _GLSL_DEFINES.search(self.glsl)):
                raise OwnModelError(f"own model {self.name}: glsl must be GLSL source defining {GLSL_SIGNATURE} "
                                    "(docs/models.md)")
            for p in self.params:
                if not _GLSL_MEMBER.match(p.name):
                    raise OwnModelError(f"own model {self.name}: parameter {p.name!r} cannot be a member of its "
                                        "GLSL struct BrdfParams (letters, digits and _, a letter first, no gl_ "
                                        "prefix, no __); rename it or leave glsl out")

    def __repr__(self):
        where = f", {self.source[0]} sha256 {self.source[1][:12]}" if self.source else ""
        return f"OwnModel({self.name!r}{where}) {NOT_STORED}"

    @property
    def model_string(self) -> str:
        return PREFIX + self.name

    @property
    def record(self) -> dict | None:
        """A result's ``model_file`` record of the file it was loaded from: {"name", "sha256",
        "path"} (``path`` for the reader's information only), or None (declared in Python)."""
        if self.source is None:
            return None
        return {"name": self.source[0], "sha256": self.source[1],
                **({"path": self.path} if self.path is not None else {})}

    @property
    def term(self) -> Term:
        """The model as the one Term of its spec (brdf.spec.terms): not fused (jax.grad), no glTF,
        reciprocal only when found or declared so."""
        return Term(name=self.model_string, hint=self.description, params=self.params, fused=False,
                    gltf=GltfRule(note=GLTF_NOTE), reciprocal=self.reciprocal is True)


def _finite(x: object) -> bool:
    """A finite real number (not a string, not a bool)."""
    return isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(float(x))


GLTF_NOTE = ("{name} is a model of your own: glTF cannot represent it and no conversion is guessed "
             "(no exported material; `brdf-fit export MEASURED` ships the export-first fit of the glTF family)")

_REGISTRY: dict[str, OwnModel] = {}
_FILES: dict[tuple, object] = {}       # (file name, sha256, name) -> what load_bytes registered, and the bytes


def registered() -> list[OwnModel]:
    """The own models registered in this process, by name."""
    return [_REGISTRY[name] for name in sorted(_REGISTRY)]


def is_own(model: object) -> bool:
    """True for the model string (or ModelSpec) of a model of one's own."""
    return str(model).strip().lower().startswith(PREFIX)


def register(model: OwnModel) -> OwnModel:
    """Make ``own:NAME`` name ``model`` (a later registration of the name replaces it)."""
    if not isinstance(model, OwnModel):
        raise OwnModelError(f"{model!r} is not a model declaration (brdf.own.OwnModel)")
    _REGISTRY[model.name] = model
    return model


def lookup(name: str) -> OwnModel:
    """The registered own model ``name`` (without the own: prefix); OwnModelError if none."""
    if name not in _REGISTRY:
        raise OwnModelError(f"{PREFIX}{name} is a model of your own, not loaded here: give its file on the "
                            f"command line (--model FILE.py:NAME or --model-file FILE.py) or call "
                            f"brdf.own.load_file(FILE.py) first")
    return _REGISTRY[name]


def load_file(path: str | pathlib.Path, name: str | None = None) -> OwnModel | list[OwnModel]:
    """Import the user's file ``path`` and register its model ``name`` (a variable holding an
    OwnModel), or every OwnModel in it when ``name`` is None; each is checked on a few
    direction pairs (``check``).  OwnModelError (one line) for a missing file, a file that
    fails to import, no such name, or a name that is no model declaration."""
    return load_bytes(path, read_file(path), name)


def read_file(path: str | pathlib.Path) -> bytes:
    """The bytes of the model file ``path``; OwnModelError (one line) when it cannot be read."""
    path = pathlib.Path(path)
    if path.is_dir():
        raise OwnModelError(f"{path}: is a folder, not a model file (give the Python file: PATH.py)")
    if not path.is_file():
        raise OwnModelError(f"{path}: no such model file")
    try:
        return path.read_bytes()
    except OSError as err:
        raise OwnModelError(f"{path}: cannot read the model file ({err.strerror or err})") from None


def load_bytes(path: str | pathlib.Path, data: bytes, name: str | None = None) -> OwnModel | list[OwnModel]:
    """``load_file`` of a file's bytes ``data`` (a batch worker's copy: the same models, sha256,
    file name and path as where it was read).  ``path`` is kept as given (``OwnModel.path``):
    a result records what the user typed, which another path to the same bytes is not."""
    given, path = os.fspath(path), pathlib.Path(path)
    digest = hashlib.sha256(data).hexdigest()
    key = (given, digest, name)
    if key in _FILES:       # loaded before (a batch's next file): the same objects, its programs compiled
        found = _FILES[key][0]
        for model in found if name is None else [found]:
            register(model)
        return found
    spec = importlib.util.spec_from_file_location(f"brdf_own_{digest[:16]}", path)
    module = importlib.util.module_from_spec(spec)
    try:
        with import_deadline(str(path)), no_hard_exit(), user_code(str(path), "importing it"):   # own_guard
            exec(compile(data, str(path), "exec"), module.__dict__)
    except OwnModelError as err:        # a declaration refused while the file ran: say which file
        raise OwnModelError(str(err) if str(err).startswith(f"{path}: ") else f"{path}: {err}") from None
    if name is None:
        named = {}      # one object under two variables is one model; two objects of one name are refused
        for variable, v in vars(module).items():
            if isinstance(v, OwnModel) and named.setdefault(v.name, (variable, v))[1] is not v:
                raise OwnModelError(f"{path}: {named[v.name][0]} and {variable} both declare {v.model_string}: "
                                    "rename one of the models")
        found = [v for _, v in named.values()]
        if not found:
            raise OwnModelError(f"{path}: declares no model (brdf.own.OwnModel)")
    else:
        if name not in vars(module):
            raise OwnModelError(f"{path}: no name {name!r} in it")
        found = [vars(module)[name]]
        if not isinstance(found[0], OwnModel):
            raise OwnModelError(f"{path}: {name} is a {type(found[0]).__name__}, not a model declaration "
                                "(brdf.own.OwnModel)")
    with no_hard_exit():
        out = [register(check(guarded(dataclasses.replace(m, source=(path.name, digest), path=given))))
               for m in found]
    _FILES[key] = (out if name is None else out[0], data)
    return _FILES[key][0]


def files_of(models: typing.Iterable[str]) -> tuple[tuple[str, bytes], ...]:
    """(path as the user gave it, bytes) of the files the own models among ``models`` (model
    strings) were loaded from: what a batch's task carries, so that a worker process or a
    Dask worker loads the same models (``load_sources``) and records the same path, without
    reading a path of its own.  The file's name is the path's last part."""
    out = {}
    for text in models:
        if is_own(text):
            model = lookup(str(text).strip()[len(PREFIX):])
            if model.source:      # (one sha256, one file's bytes: under whichever path they were read)
                data = next(d for (_, sha, _), (_, d) in _FILES.items() if sha == model.source[1])
                given = model.path or model.source[0]
                out[given, model.source[1]] = (given, data)
    return tuple(out.values())


def load_sources(files: typing.Iterable[tuple[str, bytes]]) -> None:
    """Register every model of each (path, bytes) of ``files_of`` (a batch worker)."""
    for given, data in files:
        loaded = {(m.path, m.source[1]) for m in _REGISTRY.values() if m.source}
        if (given, hashlib.sha256(data).hexdigest()) not in loaded:     # (this process: loaded already)
            load_bytes(given, data)


def guarded(model: OwnModel) -> OwnModel:
    """``model`` with its evaluate and start rules run behind ``own_guard.user_code``: their
    prints on stderr, their exceptions and exits one line naming the file (and parameter)."""
    where = label(model)
    params = tuple(p if not p.start.rule else
                   dataclasses.replace(p, start=dataclasses.replace(p.start, rule=guarded_rule(where, p, p.start.rule)))
                   for p in model.params)
    return dataclasses.replace(model, params=params, evaluate=guarded_evaluate(where, model.evaluate))


def check(model: OwnModel) -> OwnModel:
    """``model`` if its evaluate runs (eagerly, under jax.jit and jax.grad) at its defaults and
    at each parameter's bounds, giving (pairs, 3) finite real values, and its start rules run;
    else OwnModelError saying what it did (brdf/own_guard.py: check).  Its ``reciprocal`` is
    what the check found, where the file left it out."""
    from .own_guard import check as check_declaration
    reciprocal = check_declaration(model, guarded_evaluate(label(model), model.evaluate))   # (a guard twice is one)
    return model if model.reciprocal is not None else dataclasses.replace(model, reciprocal=reciprocal)


RECORD_KEYS = ({"name", "sha256"}, {"name", "sha256", "path"})   # a model_file record (path: since issue 60)


def check_result(spec: str, record: object) -> None:
    """Check a result's model string ``spec`` and its ``model_file`` record: the record is
    None or {"name": str, "sha256": str} with, in results written since issue 60, "path":
    str (what the user typed; data, never opened), and a model of one's own is registered
    from that file (``check_source``).  OwnModelError otherwise; never imports anything."""
    if record is not None and not (isinstance(record, dict) and set(record) in RECORD_KEYS
                                   and all(isinstance(v, str) for v in record.values())):
        raise OwnModelError("'model_file' must be an object of the strings name and sha256 (and path)")
    if is_own(spec):
        check_source(spec.strip()[len(PREFIX):], record)


def check_source(name: str, record: object) -> OwnModel:
    """The registered model ``own:NAME`` of a result whose ``model_file`` record is ``record``
    ({"name", "sha256"[, "path"]} or None): OwnModelError when it is not registered, or
    registered from another file or another version of it.  Never imports anything: the
    name and path it holds are quoted as data, never offered as a command's argument."""
    file = record.get("name") if isinstance(record, dict) else None
    digest = record.get("sha256") if isinstance(record, dict) else None
    given = record.get("path") if isinstance(record, dict) else None
    if name not in _REGISTRY:
        if file:
            typed = f", given as {_as_data(given)} when fitted" if given else ""
            raise OwnModelError(f"{PREFIX}{name}: the result says its model file was {_as_data(file)} "
                                f"(sha256 {str(digest)[:12]}...{typed}), not loaded here; a file a result "
                                "names is never imported: give your copy of that model file with "
                                "--model-file PATH.py (in Python: brdf.own.load_file(path) first)")
        return lookup(name)
    model = _REGISTRY[name]
    if digest is not None and (model.source is None or model.source[1] != digest):
        loaded = f"{model.source[0]} sha256 {model.source[1][:12]}..." if model.source else "Python"
        raise OwnModelError(f"{PREFIX}{name}: the result says it was fitted with the model file {_as_data(file)} "
                            f"sha256 {str(digest)[:12]}..., but the model loaded here is from {loaded}: the "
                            "file changed; give the file the result was fitted with, or fit again")
    return model


def _as_data(name: object, limit: int = 60) -> str:
    """A file name read from a result, for a message: quoted (repr: control characters and
    bidirectional overrides escaped), its middle cut past ``limit`` characters; never a
    command to run."""
    text = str(name)
    if len(text) > limit:
        text = text[:limit * 2 // 3] + "..." + text[-(limit // 3):]
    return repr(text)
