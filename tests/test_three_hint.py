"""How the toolkit finds three.js, and the one line it prints when it cannot
(brdf_fit.report.web_viewer.install_hint): ``brdf-fit library`` run from a package
laid out as pip installs it (no package.json beside it) prints the README's exact
line, as ``brdf-fit report`` does; ``BRDF_FIT_THREE_DIR`` with a quoted, unexpanded
``~`` is expanded, and a folder without three.js is named in that line."""

import os
import pathlib
import shutil
import subprocess
import sys

import numpy as np
import pytest

from brdf_fit.origin import LIBRARIES
from brdf_fit.report import web_viewer
from brdf_fit.report.web_viewer import THREE_DIR_VARIABLE, THREE_ENTRY
from data_loaders.samples import write_samples
from fitting.synthetic import synthetic_measured

ROOT = pathlib.Path(__file__).resolve().parent.parent
FAST = ["--models", "gltf", "--samples", "2000", "--starts", "1", "--jobs", "1"]


def _installed_copy(site):
    """The five packages copied into ``site`` as pip lays them out (no package.json above them)."""
    for name in (*LIBRARIES, "brdf_fit"):
        shutil.copytree(ROOT / name, site / name, ignore=shutil.ignore_patterns("__pycache__"))


def _table(path):
    truth = {"albedo": [0.5, 0.2, 0.1], "roughness": 0.4, "f0": [0.04] * 3}
    m = synthetic_measured("ggx+lambert", truth, grid=(8, 8, 16, 1), noise=0.0, seed=1)
    keep = np.flatnonzero(m.valid)
    write_samples(path, m.wi[keep], m.wo[keep], m.values[keep], weights=m.weights[keep],
                  material="plain", isotropic=True)


def _library(site, data, out, **env):
    environment = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", THREE_DIR_VARIABLE)}
    environment.update(PYTHONPATH=str(site), MPLBACKEND="Agg", **env)
    return subprocess.run([sys.executable, "-m", "brdf_fit", "library", str(data), "--out", str(out), *FAST],
                          cwd=out.parent, env=environment, capture_output=True, text=True, timeout=600)


def test_library_from_an_installed_package_prints_the_readmes_three_line(tmp_path, monkeypatch):
    site = tmp_path / "site-packages"
    _installed_copy(site)
    (tmp_path / "data").mkdir()
    _table(tmp_path / "data" / "plain.npz")
    proc = _library(site, tmp_path / "data", tmp_path / "lib")
    assert proc.returncode == 0, proc.stderr
    monkeypatch.setattr(web_viewer, "PROJECT_ROOT", site)
    monkeypatch.delenv(THREE_DIR_VARIABLE, raising=False)
    hint = web_viewer.install_hint()
    assert "npm install --prefix ~/.brdf-fit three@" in hint
    assert proc.stderr.splitlines().count(f"3D viewer not shown: {hint}") == 1
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert f"\n{hint}\n" in readme

    # the same run with three.js named through a quoted '~/...': found, no line, a viewer on the page
    three = ROOT / "node_modules" / "three"
    if not (three / THREE_ENTRY).is_file():
        pytest.skip("three.js is not installed (node_modules/three; make test runs npm ci)")
    home = tmp_path / "home"
    (home / ".brdf-fit" / "node_modules").mkdir(parents=True)
    (home / ".brdf-fit" / "node_modules" / "three").symlink_to(three)
    proc = _library(site, tmp_path / "data", tmp_path / "lib", HOME=str(home),
                    **{THREE_DIR_VARIABLE: "~/.brdf-fit/node_modules/three"})
    assert proc.returncode == 0, proc.stderr
    assert "three.js is not installed" not in proc.stderr
    assert (tmp_path / "lib" / "materials" / web_viewer.BUNDLE_NAME).is_file()


def test_a_quoted_tilde_is_expanded(tmp_path, monkeypatch):
    folder = tmp_path / ".brdf-fit" / "node_modules" / "three"
    (folder / "build").mkdir(parents=True)
    (folder / THREE_ENTRY).write_text("export { };\n")
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv(THREE_DIR_VARIABLE, "~/.brdf-fit/node_modules/three")
    assert web_viewer.three_dir() == folder


@pytest.mark.parametrize("installed", [False, True])
def test_a_folder_without_three_is_named_in_one_line(tmp_path, monkeypatch, installed):
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv(THREE_DIR_VARIABLE, "~/nowhere/three")
    if installed:
        monkeypatch.setattr(web_viewer, "PROJECT_ROOT", tmp_path / "site-packages")
    assert web_viewer.three_dir() is None
    with pytest.raises(web_viewer.ViewerUnavailable) as err:
        web_viewer.write_three_bundle(tmp_path)
    line = str(err.value)
    assert "\n" not in line
    assert line.startswith(f"three.js is not installed where {THREE_DIR_VARIABLE} points: "
                           f"{tmp_path / 'nowhere' / 'three'} has no {THREE_ENTRY}")
    assert ("npm install --prefix ~/.brdf-fit three@" in line) == installed
    assert ("npm ci" in line) == (not installed)
