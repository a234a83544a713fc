"""The layers of ../shared/DESIGN.md, read from the source (no import is run).

Libraries below, the application on top: ``brdf`` and ``data_loaders`` import
no other package of the project, ``shaders`` only those two, ``fitting`` (the
engine) those two as well, and ``brdf_fit`` (the application) any of them.
Every import counts, module-level, inside a function, or for type checking
only.  No module imports another that imports it back (no cycle at all), the
engine (and the models and loaders below it) imports no command-line,
progress, Dask or HTTP code, and no module of the packages is over 400 lines.
"""

import ast
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGES = ("brdf", "data_loaders", "shaders", "fitting", "brdf_fit")
#: what each package may import of the project (itself always)
ALLOWED = {
    "brdf": set(),
    "data_loaders": set(),
    "shaders": {"brdf", "data_loaders"},
    "fitting": {"brdf", "data_loaders"},
    "brdf_fit": {"brdf", "data_loaders", "shaders", "fitting"},
}
#: what the engine and the libraries never import (the application's business)
APPLICATION_ONLY = ("argparse", "tqdm", "dask", "distributed", "http", "urllib", "socket", "socketserver")
MAX_LINES = 400


def _modules():
    """{dotted module name: path} of every module of the project's packages."""
    out = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            out[name] = path
    return out


MODULES = _modules()


def _resolve(name):
    """The project module a dotted import name lands in (a module, else its package), or None."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _imports(module, path):
    """(project modules, top-level names of everything) that ``module`` imports."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found, names = set(), set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[:len(anchor) - (node.level - 1)]
                base = ".".join(anchor + ([base] if base else []))
            # ``from X import Y`` imports the module X.Y where there is one, else X
            targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base
                       for alias in node.names]
        else:
            continue
        for target in targets:
            names.add(target.split(".")[0])
            resolved = _resolve(target)
            if resolved and resolved != module:
                found.add(resolved)
    return found, names


GRAPH = {}
NAMES = {}
for _module, _path in MODULES.items():
    GRAPH[_module], NAMES[_module] = _imports(_module, _path)


def test_the_packages_are_found():
    """The walk sees every package and the modules the layers are about."""
    for module in ("brdf.model", "data_loaders.merl", "shaders.render", "fitting.fit", "brdf_fit.cli",
                   "brdf_fit.batch.run", "brdf_fit.report.pages", "brdf_fit.export.gltf"):
        assert module in MODULES
    assert "fitting.fit" in GRAPH["brdf_fit.batch.task"]
    assert "brdf_fit.errors" in GRAPH["brdf_fit.cli"]      # a relative import, resolved


@pytest.mark.parametrize("package", PACKAGES)
def test_imports_run_downward(package):
    upward = sorted(f"{module} imports {target}" for module, targets in GRAPH.items()
                    if module.split(".")[0] == package for target in targets
                    if target.split(".")[0] not in ALLOWED[package] | {package})
    assert not upward


def test_no_import_cycle():
    """No module reaches itself through the imports (Tarjan's strongly connected components)."""
    index, low, stack, on_stack, cycles = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(GRAPH[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in sorted(GRAPH):
        if v not in index:
            visit(v)
    assert not cycles


@pytest.mark.parametrize("package", ("brdf", "data_loaders", "fitting"))
def test_libraries_import_no_application_code(package):
    found = sorted(f"{module} imports {name}" for module, names in NAMES.items()
                   if module.split(".")[0] == package for name in names if name in APPLICATION_ONLY)
    assert not found


def test_no_logging_set_up_below_the_application():
    """Libraries log through ``logging.getLogger``; only the command line configures logging."""
    offenders = [str(path.relative_to(ROOT)) for module, path in MODULES.items()
                 if not module.startswith("brdf_fit")
                 and any(call in path.read_text() for call in ("basicConfig(", "addHandler(", "setLevel("))]
    assert not offenders


def test_modules_stay_short():
    long = sorted(f"{path.relative_to(ROOT)}: {n} lines" for path in MODULES.values()
                  if (n := len(path.read_text().splitlines())) > MAX_LINES)
    assert not long
