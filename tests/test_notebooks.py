"""The analysis notebooks run top to bottom (nbclient), with outputs
stripped in git, and their
outputs hold the pictures and the HTML of docs/notebooks.md: figures and
renders as image/png, and as text/html the objects that show themselves (a
MeasuredBRDF, a FitResult with its spheres or the one line saying why not,
the inline 3D viewer or its one line, results_table's DataFrame).

The kernel is "python3" as jupyter_client resolves it from the running
interpreter (its kernelspec says ``python``, which jupyter_client replaces by
``sys.executable``): the first cell prints the kernel's interpreter and the
test checks it is this virtualenv's.
"""

import base64
import os
import pathlib
import sys

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

ROOT = pathlib.Path(__file__).resolve().parent.parent
NOTEBOOKS = ROOT / "notebooks"
# a hang guard per cell, not a speed target (no timing assertions in tests: how long
# the notebooks take is measured, e.g. 2-3 min each on 2 cores, not asserted)
CELL_TIMEOUT = 900

# what each notebook must print: its key results
EXPECTED = {
    "quickstart": ["model ", "M1", "exported material", "KHR_materials_ior", "extras keep the fit"],
    "diffuse_models": ["best M1", "rim bias", "retro bias", "ggx+cod_wwii", "ggx+frostbite"],
    "batch_analysis": ["0 failed", "median M1", "+clearcoat gain", "worst material for ggx+lambert"],
}

# what each notebook must show as HTML (class names of brdf_fit.notebook's and pandas' HTML)
EXPECTED_HTML = {
    "quickstart": ["brdf-measured", "brdf-fit-result", "brdf-viewer", "class=\"dataframe\""],
    "diffuse_models": ["brdf-fit-result", "class=\"dataframe\""],
    "batch_analysis": ["class=\"dataframe\""],
}
SPHERES = ('alt="measured | fitted | difference"', "spheres not shown: ")


def _stream_text(nb):
    return "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code"
                   for o in c.outputs if o.get("output_type") == "stream")


def _rich(nb, mime):
    """The ``mime`` parts of every display / result output."""
    return [o["data"][mime] for c in nb.cells if c.cell_type == "code" for o in c.outputs
            if mime in o.get("data", {})]


@pytest.mark.parametrize("name", list(EXPECTED))
def test_notebook_is_stored_without_outputs(name):
    nb = nbformat.read(NOTEBOOKS / f"{name}.ipynb", as_version=4)
    nbformat.validate(nb)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code and all(not c.outputs and c.execution_count is None for c in code)
    # the installed package, as a user has it: no path tricks, no global JAX flags set by hand
    for needle in ("sys.path", "jax_enable_x64", "enable_x64"):
        assert not any(needle in c.source for c in code), f"{name} uses {needle}"


@pytest.mark.parametrize("name", list(EXPECTED))
def test_notebook_runs(name, tmp_path):
    nb = nbformat.read(NOTEBOOKS / f"{name}.ipynb", as_version=4)
    client = nbclient.NotebookClient(nb, kernel_name="python3", timeout=CELL_TIMEOUT,
                                     resources={"metadata": {"path": str(NOTEBOOKS)}})
    # the notebooks' temporary MERL tables go under pytest's tmp_path even if a cell fails
    client.execute(env=dict(os.environ, TMPDIR=str(tmp_path)))    # raises CellExecutionError on a failing cell
    text = _stream_text(nb)
    python = next(line.split("python:", 1)[1].strip() for line in text.splitlines()
                  if line.startswith("python:"))
    assert os.path.realpath(python) == os.path.realpath(sys.executable)
    package = next(line.split("fitting:", 1)[1].strip() for line in text.splitlines()
                   if line.startswith("fitting:"))
    assert os.path.realpath(package) == os.path.realpath(ROOT / "fitting")     # the editable install
    for needle in EXPECTED[name]:
        assert needle in text, f"{name} did not print {needle!r}"
    images = _rich(nb, "image/png")
    assert len(images) >= 3, f"{name} showed {len(images)} figures"
    assert all(base64.b64decode(png)[:8] == b"\x89PNG\r\n\x1a\n" for png in images)
    html = "".join(_rich(nb, "text/html"))
    for needle in EXPECTED_HTML[name]:
        assert needle in html, f"{name} showed no HTML with {needle!r}"
    if "brdf-fit-result" in EXPECTED_HTML[name]:       # a FitResult's spheres, or the one line why not
        assert any(s in html for s in SPHERES)
