"""What a newcomer installs: the wheel carries the MIT LICENSE and the five top-level
packages, and a file or folder that shadows one of the four generic library names
(``brdf``, ``fitting``, ``data_loaders``, ``shaders``) is one line naming it and exit
code 2, from ``python -m brdf_fit`` and from the console script (brdf_fit.origin,
docs/packaging.md)."""

import os
import pathlib
import shutil
import subprocess
import sys
import zipfile

import pytest

from brdf_fit.origin import LIBRARIES, shadowed

ROOT = pathlib.Path(__file__).resolve().parent.parent


def _env(**extra):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(extra)
    return env


def test_this_process_imports_this_distributions_libraries():
    assert shadowed() is None
    import brdf_fit
    for name in LIBRARIES:
        module = __import__(name)
        assert pathlib.Path(module.__file__).resolve().parent.parent == \
            pathlib.Path(brdf_fit.__file__).resolve().parent.parent


def test_a_module_in_the_working_directory_is_one_line_naming_it(tmp_path):
    """``python -m`` puts the working directory first on sys.path: a fitting.py there
    would be imported instead of the engine (a traceback before)."""
    (tmp_path / "fitting.py").write_text("raise SystemExit('the wrong fitting was imported')\n")
    proc = subprocess.run([sys.executable, "-m", "brdf_fit", "models"], cwd=tmp_path, env=_env(),
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert proc.stdout == ""
    assert proc.stderr.count("\n") == 1
    assert proc.stderr.startswith("brdf-fit: the package 'fitting' is imported from "
                                  f"{(tmp_path / 'fitting.py').resolve()}, which shadows brdf-fit's "
                                  f"{ROOT / 'fitting'}")


def test_a_folder_on_pythonpath_is_one_line_from_the_console_script(tmp_path):
    script = pathlib.Path(sys.executable).parent / "brdf-fit"
    if not script.is_file():
        pytest.skip("no brdf-fit console script beside this Python")
    (tmp_path / "shaders").mkdir()
    (tmp_path / "shaders" / "__init__.py").write_text("")
    proc = subprocess.run([str(script), "models"], cwd=tmp_path, env=_env(PYTHONPATH=str(tmp_path)),
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1
    assert f"the package 'shaders' is imported from {(tmp_path / 'shaders' / '__init__.py').resolve()}" \
        in proc.stderr


def test_without_a_shadow_the_console_script_runs(tmp_path):
    script = pathlib.Path(sys.executable).parent / "brdf-fit"
    if not script.is_file():
        pytest.skip("no brdf-fit console script beside this Python")
    proc = subprocess.run([str(script), "models"], cwd=tmp_path, env=_env(), capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "ggx+lambert" in proc.stdout


def test_the_wheel_carries_the_license_and_the_five_packages(tmp_path):
    # built from a copy: pip builds in the source tree, which would leave build/ and an .egg-info in the clone
    source = tmp_path / "source"
    for package in (*LIBRARIES, "brdf_fit"):
        shutil.copytree(ROOT / package, source / package, ignore=shutil.ignore_patterns("__pycache__"))
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(ROOT / name, source / name)
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", str(source), "-w", str(tmp_path)],
                          capture_output=True, text=True, timeout=300, env=_env())
    if proc.returncode != 0 and "setuptools" in proc.stderr and "satisf" in proc.stderr:
        pytest.skip("pip cannot get setuptools to build the wheel (offline?)")
    assert proc.returncode == 0, proc.stderr
    (wheel,) = tmp_path.glob("brdf_fit-*.whl")
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        info = next(n.split("/")[0] for n in names if n.endswith(".dist-info/METADATA"))
        license_text = z.read(f"{info}/licenses/LICENSE").decode()
        metadata = z.read(f"{info}/METADATA").decode().splitlines()
        entry_points = z.read(f"{info}/entry_points.txt").decode()
    assert license_text == (ROOT / "LICENSE").read_text()
    assert license_text.startswith("MIT License\n\nCopyright (c) the brdf-fit authors\n")
    assert "License-Expression: MIT" in metadata and "License-File: LICENSE" in metadata
    assert {n.split("/")[0] for n in names} == {"brdf", "brdf_fit", "data_loaders", "fitting", "shaders", info}
    assert "brdf-fit = brdf_fit.__main__:run" in entry_points


def test_the_readme_shows_the_three_line_an_installed_package_prints(tmp_path, monkeypatch):
    """The README's three.js line is the one ``report`` and ``library`` print from a wheel
    (no package.json beside the installed package), word for word."""
    import brdf_fit.report.web_viewer as web_viewer
    monkeypatch.setattr(web_viewer, "PROJECT_ROOT", tmp_path / "site-packages")
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert f"\n```\n{web_viewer.install_hint()}\n```\n" in readme
    assert "Matusik" in readme and "Filip & Vávra 2014" in readme and "Dupuy & Jakob 2018" in readme
