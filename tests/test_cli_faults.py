"""Smaller faults of the command line: bare ``brdf-fit``, an empty ``--out``, and
render against a measured file that is not the one the fit was made on."""

import os
import subprocess
import sys

import pytest

from brdf_fit.cli import main

from test_cli_corpus import FAST, _check_clean_error, _samples

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def test_bare_brdf_fit_prints_help_on_stderr_and_exits_2():
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-m", "brdf_fit"], env=env, capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.startswith("usage: brdf-fit") and "COMMAND" in proc.stderr
    assert proc.stderr.strip().splitlines()[-1] == "brdf-fit: error: no command given (see --help)"


@pytest.mark.parametrize("command", ["fit", "batch", "report", "demo"])
def test_an_empty_out_is_refused(tmp_path, capsys, monkeypatch, command):
    monkeypatch.chdir(tmp_path)
    good = _samples(tmp_path / "good.npz")
    before = sorted(os.listdir(tmp_path))
    argv = {"fit": ["fit", str(good)], "batch": ["batch", str(good)], "report": ["report", str(tmp_path)],
            "demo": ["demo"]}[command]
    code = main([*argv, "--out", "", *(FAST if command in ("fit", "batch") else [])])
    _check_clean_error(capsys, code, command, ["--out", "empty"])
    assert sorted(os.listdir(tmp_path)) == before


@pytest.fixture
def fitted(tmp_path):
    good = _samples(tmp_path / "good.npz")
    assert main(["fit", str(good), "--out", str(tmp_path / "results"), *FAST]) == 0
    return good, tmp_path / "results" / "good.ggx+lambert.json"


@pytest.mark.parametrize("how", ["--measured", "provenance"])
def test_render_warns_when_the_measured_file_is_not_the_fitted_one(fitted, tmp_path, capsys, how):
    from shaders.gl import gl_available
    if not gl_available():
        pytest.skip("no OpenGL here")
    good, result = fitted
    fitted_bytes = good.read_bytes()
    _samples(good, scale=1.5)                    # the file was measured again since the fit
    capsys.readouterr()
    argv = ["render", "-q", str(result), "--out", str(tmp_path / "x.png"), "--size", "128"]
    code = main(argv + (["--measured", str(good)] if how == "--measured" else []))
    err = capsys.readouterr().err
    assert code == 0, err
    assert err.strip().splitlines() == [
        f"brdf-fit render: warning: {good}: the measured file differs from the one the fit was made on "
        "(sha256); the comparison shows another measurement"], err
    good.write_bytes(fitted_bytes)               # the same bytes again: no warning
    assert main(argv + ["--measured", str(good)]) == 0
    assert capsys.readouterr().err == ""


def test_a_numpy_runtime_warning_is_one_line(tmp_path, capsys, monkeypatch):
    """A floating-point warning no source fix caught yet: one line, not numpy's two."""
    import warnings
    import numpy as np
    import brdf_fit.commands as commands

    def overflowing_info(args):
        with warnings.catch_warnings():
            warnings.simplefilter("always")       # the test's own process may have seen it before
            np.exp(np.array([1000.0]))
        return 0

    monkeypatch.setattr(commands, "info", overflowing_info)      # main's parser binds it when built
    assert main(["info", str(_samples(tmp_path / "x.npz"))]) == 0
    err = capsys.readouterr().err
    assert err.strip().splitlines() == ["brdf-fit info: warning: numerical warning in tests/test_cli_faults.py: "
                                        "overflow encountered in exp (extreme values in the input?)"], err
