"""`brdf-fit render` end to end through brdf_fit.render.render_main (the function
brdf_fit/cli.py calls): result JSON -> PNG, with and without a measured file."""

import json

import numpy as np
import pytest

from shaders.gl import gl_available

ok, reason = gl_available()
pytestmark = pytest.mark.skipif(not ok, reason=f"no OpenGL 4.3 context: {reason}")

from brdf_fit import render as cli  # noqa: E402
from shaders.hdr import write_hdr  # noqa: E402


def _result(tmp_path, spec="ggx+lambert", params=None):
    params = params or {"albedo": [0.6, 0.3, 0.2], "roughness": 0.35, "f0": [0.04, 0.04, 0.04]}
    path = tmp_path / "result.json"
    path.write_text(json.dumps({"spec": spec, "parameters": params, "errors": {}, "schema_version": 1}))
    return path


def _png_size(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def test_render_main_writes_a_png(tmp_path, capsys):
    out = tmp_path / "render.png"
    assert cli.render_main(_result(tmp_path), out_path=out, size=64) == cli.OK
    assert _png_size(out) == (64, 64)
    assert "wrote" in capsys.readouterr().out


def test_render_main_with_user_hdr_environment(tmp_path):
    env = np.ones((16, 32, 3), np.float32) * np.linspace(0.1, 2.0, 32)[None, :, None]
    write_hdr(tmp_path / "env.hdr", env)
    out = tmp_path / "env.png"
    assert cli.render_main(_result(tmp_path), env_path=tmp_path / "env.hdr", out_path=out, size=48) == cli.OK
    assert _png_size(out) == (48, 48)


def test_render_main_comparison_with_a_measured_file(tmp_path):
    utia = pytest.importorskip("data_loaders.utia")
    data = np.full((3, 6, 48, 6, 48), 0.2)                # a grey Lambertian-ish table
    utia.write_utia(tmp_path / "grey.bin", data)
    out = tmp_path / "cmp.png"
    status = cli.render_main(_result(tmp_path), measured_path=tmp_path / "grey.bin", out_path=out, size=256)
    assert status == cli.OK
    w, h = _png_size(out)
    from shaders.annotate import FOOTER, HEADER
    assert h == HEADER + 128 + FOOTER and w == 3 * 128 + 8     # titles above, colour bar below


@pytest.mark.parametrize("content, message", [
    ("{", "not valid JSON"),
    ('{"spec": "ggx+nonsense", "parameters": {}}', "nonsense"),
    ('{"spec": "ggx+lambert", "parameters": {"albedo": 0.5, "roughness": 0.3, "f0": [0.04]}}', "albedo"),
    ('[1, 2]', "not a fit result"),
])
def test_render_main_bad_results_are_one_line_errors(tmp_path, capsys, content, message):
    path = tmp_path / "bad.json"
    path.write_text(content)
    assert cli.render_main(path, out_path=tmp_path / "x.png", size=32) == cli.BAD_INPUT
    err = capsys.readouterr().err
    assert message in err and str(path) in err and "Traceback" not in err
    assert not (tmp_path / "x.png").exists()


def test_render_main_bad_measured_and_env_files(tmp_path, capsys):
    (tmp_path / "junk.bin").write_bytes(b"\0" * 100)
    assert cli.render_main(_result(tmp_path), measured_path=tmp_path / "junk.bin",
                           out_path=tmp_path / "x.png", size=32) == cli.BAD_INPUT
    assert "junk.bin" in capsys.readouterr().err
    (tmp_path / "bad.hdr").write_bytes(b"nope")
    assert cli.render_main(_result(tmp_path), env_path=tmp_path / "bad.hdr",
                           out_path=tmp_path / "x.png", size=32) == cli.BAD_INPUT
    assert "bad.hdr" in capsys.readouterr().err
