"""Fit result files are validated once, on load (``FitResult.load``), and every
command that reads one (export, eval, render, report, view) turns a bad file
into one ``brdf-fit COMMAND: error: PATH: ...`` line and exit status 2, with no
traceback and no output written.

The corpus of bad files is generated here, from a valid result, in tmp_path.
"""

import json
import math

import numpy as np
import pytest

from brdf.model import parameter_schema, parse_model
from brdf_fit.cli import main
from brdf_fit.export.gltf import ExportError, write_gltf_file
from brdf_fit.report.pages import collect_results
from fitting.result import (MAX_DEPTH, MAX_RESULT_BYTES, SCHEMA_VERSION, FitResult, NotAResultError,
                            ResultFileError)

SPEC = "ggx+lambert"
PNG = b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00\x00\x01\x00\x00\x00\x01\x08\x02\x00\x00\x00\x90wS\xde"


def valid_result(spec=SPEC):
    """A complete result of ``spec`` at the schema's defaults (as a fit would write it)."""
    params = {p.name: ([p.default] * 3 if p.size == 3 else p.default) for p in parameter_schema(parse_model(spec))}
    return FitResult(
        spec=spec, parameters=params,
        errors={"m1": 0.0123, "m1_per_channel": [0.011, 0.012, 0.014], "loss_name": "log",
                "loss": 0.0123, "loss_per_channel": [0.011, 0.012, 0.014],
                "image": 0.021, "image_per_channel": [0.02, 0.021, 0.022], "exported_model": "gltf",
                "exported_m1": 0.0131, "exported_image": 0.023},
        optimizer={"name": "lbfgs", "starts": 1, "evaluations": 30, "converged": True, "seconds": 0.5,
                   "seconds_total": 0.7, "samples": 5000, "samples_full": 5000, "max_theta": 80.0,
                   "seed": 0, "runs": [{"stage": 0, "samples": 5000, "loss": 0.0123}]},
        provenance={"file": None, "sha256": None, "format": "npz", "material": "test-material"})


def _text():
    return valid_result().to_json()


def _edit(change):
    """JSON text of the valid result after ``change(data)`` edited its dict."""
    data = json.loads(_text())
    change(data)
    return json.dumps(data, indent=2)


def _set(*keys_value):
    *keys, value = keys_value

    def change(data):
        target = data
        for k in keys[:-1]:
            target = target[k]
        target[keys[-1]] = value
    return change


def _token(path_keys, token):
    """JSON text with the value at ``path_keys`` replaced by a bare token (NaN, Infinity, 1e999...)."""
    marker = "__TOKEN__"
    return _edit(_set(*path_keys, marker)).replace(f'"{marker}"', token)


def _nested(depth):
    value = 0
    for _ in range(depth):
        value = [value]
    return value


# name -> (bytes or text or callable(path) writing the file, a word the message must contain)
CORPUS = {
    "not_json": ("this is not JSON {", "not valid JSON"),
    "png_bytes": (PNG, "PNG"),
    "latin1_text": (_text().replace("test-material", "mat\u00e9riau").encode("latin-1"), "UTF-8"),
    "empty": ("", "empty"),
    "whitespace": ("  \n\t\n", "empty"),
    "deep_brackets": ("[" * 200_000, "nested"),
    "deep_valid_json": (lambda: _edit(_set("optimizer", "deep", _nested(MAX_DEPTH + 5))), "nested"),
    "nan_parameter": (lambda: _token(["parameters", "roughness"], "NaN"), "NaN"),
    "infinity_colour": (lambda: _token(["parameters", "albedo"], "[0.5, Infinity, 0.5]"), "Infinity"),
    "minus_infinity_m1": (lambda: _token(["errors", "m1"], "-Infinity"), "Infinity"),
    "overflowing_number": (lambda: _token(["parameters", "roughness"], "1e999"), "Infinity"),
    "nan_in_optimizer": (lambda: _token(["optimizer", "seconds"], "NaN"), "NaN"),
    "huge_integer": (lambda: _token(["parameters", "roughness"], "9" * 5000), "JSON"),
    "roughness_1.5": (lambda: _edit(_set("parameters", "roughness", 1.5)), "bounds"),
    "roughness_zero": (lambda: _edit(_set("parameters", "roughness", 0.0)), "bounds"),
    "negative_colour": (lambda: _edit(_set("parameters", "albedo", [-0.1, 0.2, 0.3])), "bounds"),
    "missing_parameter": (lambda: _edit(lambda d: d["parameters"].pop("f0")), "missing"),
    "extra_parameter": (lambda: _edit(_set("parameters", "sheen", 0.5)), "sheen"),
    "parameter_string": (lambda: _edit(_set("parameters", "roughness", "0.5")), "roughness"),
    "parameter_bool": (lambda: _edit(_set("parameters", "roughness", True)), "roughness"),
    "colour_of_two": (lambda: _edit(_set("parameters", "albedo", [0.5, 0.5])), "albedo"),
    "colour_as_number": (lambda: _edit(_set("parameters", "albedo", 0.5)), "albedo"),
    "parameters_list": (lambda: _edit(_set("parameters", [0.5, 0.3, 0.04])), "parameters"),
    "parameters_missing": (lambda: _edit(lambda d: d.pop("parameters")), "parameters"),
    "errors_list": (lambda: _edit(_set("errors", [0.01, 0.02])), "errors"),
    "errors_missing": (lambda: _edit(lambda d: d.pop("errors")), "errors"),
    "m1_negative": (lambda: _edit(_set("errors", "m1", -0.5)), "m1"),
    "m1_string": (lambda: _edit(_set("errors", "m1", "small")), "m1"),
    "m1_per_channel_short": (lambda: _edit(_set("errors", "m1_per_channel", [0.1])), "m1_per_channel"),
    "image_negative": (lambda: _edit(_set("errors", "image", -0.01)), "image"),
    "image_per_channel_short": (lambda: _edit(_set("errors", "image_per_channel", [0.1, 0.2])),
                                "image_per_channel"),
    "exported_model_number": (lambda: _edit(_set("errors", "exported_model", 3)), "exported_model"),
    "provenance_null": (lambda: _edit(_set("provenance", None)), "provenance"),
    "provenance_number": (lambda: _edit(_set("provenance", "material", 7)), "material"),
    "optimizer_string": (lambda: _edit(_set("optimizer", "lbfgs")), "optimizer"),
    "optimizer_seconds_text": (lambda: _edit(_set("optimizer", "seconds_total", "fast")), "seconds_total"),
    "toolkit_version_number": (lambda: _edit(_set("toolkit_version", 1.0)), "toolkit_version"),
    "spec_number": (lambda: _edit(_set("spec", 42)), "spec"),
    "spec_missing": (lambda: _edit(lambda d: d.pop("spec")), "spec"),
    "unknown_model": (lambda: _edit(_set("spec", "ggx+nonsense")), "nonsense"),
    "schema_version_99": (lambda: _edit(_set("schema_version", 99)), "schema_version"),
    "schema_version_text": (lambda: _edit(_set("schema_version", "1")), "schema_version"),
    "schema_version_true": (lambda: _edit(_set("schema_version", True)), "schema_version"),
    "schema_version_missing": (lambda: _edit(lambda d: d.pop("schema_version")), "schema_version"),
    "top_level_list": ("[1, 2, 3]", "not a fit result"),
    "top_level_string": ('"ggx+lambert"', "not a fit result"),
    "huge_file": (None, "too large"),
}

COMMANDS = ("export", "eval", "render", "report", "view")


def write_case(folder, name):
    content, _ = CORPUS[name]
    path = folder / f"{name}.json"
    if name == "huge_file":                       # sparse: over the cap without writing 16 MiB
        with open(path, "wb") as f:
            f.write(b"{")
            f.truncate(MAX_RESULT_BYTES + 1)
        return path
    if callable(content):
        content = content()
    if isinstance(content, str):
        content = content.encode("utf-8")
    path.write_bytes(content)
    return path


@pytest.fixture(scope="module")
def directions(tmp_path_factory):
    path = tmp_path_factory.mktemp("dirs") / "dirs.npy"
    np.save(path, np.array([[0.0, 0.0, 1.0, 0.3, 0.0, 0.9], [0.5, 0.1, 0.8, -0.4, 0.2, 0.9]]))
    return path


def command_line(command, result, tmp_path, directions):
    """(argv, output path or None) of ``command`` reading ``result``."""
    if command == "export":
        out = tmp_path / "out" / "material.gltf"
        return ["export", str(result), "--out", str(out)], out
    if command == "eval":
        out = tmp_path / "out" / "values.npy"
        return ["eval", str(result), str(directions), str(out)], out
    if command == "render":
        out = tmp_path / "out" / "render.png"
        return ["render", str(result), "--out", str(out), "--size", "64"], out
    if command == "report":
        out = tmp_path / "report"
        return ["report", str(result), "--out", str(out)], out
    return ["view", str(result), "--size", "64"], None


@pytest.mark.parametrize("name", sorted(CORPUS))
def test_load_refuses_the_bad_file(tmp_path, name):
    path = write_case(tmp_path, name)
    with pytest.raises(ResultFileError) as info:
        FitResult.load(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ")
    assert "\n" not in message
    assert CORPUS[name][1].lower() in message.lower(), message


@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.parametrize("name", sorted(CORPUS))
def test_every_command_fails_cleanly_on_a_bad_result(tmp_path, capsys, directions, name, command):
    path = write_case(tmp_path, name)
    argv, out = command_line(command, path, tmp_path, directions)
    status = main(argv)
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert status == 2, captured.err
    assert len(lines) == 1, captured.err
    assert lines[0].startswith(f"brdf-fit {command}: error: {path}: "), lines[0]
    assert CORPUS[name][1].lower() in lines[0].lower(), lines[0]
    assert "Traceback" not in captured.err and "Traceback" not in captured.out
    assert "wrote" not in captured.out
    if out is not None:
        # nothing written: no file; a report folder (made by the option check) stays empty
        assert not out.exists() or (out.is_dir() and not any(out.iterdir())), list(out.iterdir())


def test_the_corpus_covers_every_class_the_issue_names():
    needed = {"not_json", "png_bytes", "empty", "deep_brackets", "nan_parameter", "infinity_colour",
              "roughness_1.5", "negative_colour", "missing_parameter", "extra_parameter", "errors_list",
              "provenance_null", "parameters_list", "spec_number", "unknown_model", "schema_version_99",
              "huge_file"}
    assert needed <= set(CORPUS)


# --- what stays accepted --------------------------------------------------------------

def test_round_trip_save_load(tmp_path):
    result = valid_result("ggx_aniso+lambert+clearcoat")
    path = result.save(tmp_path / "r.json")
    back = FitResult.load(path)
    assert back == result
    assert back.to_json() == result.to_json()
    assert json.loads(path.read_text())["schema_version"] == SCHEMA_VERSION


@pytest.mark.parametrize("spec", ["ggx+lambert", "gltf+ior+specular+aniso+clearcoat", "ggx+oren_nayar+conductor",
                                  "ggx_aniso+burley+f90+ms+gltf_aniso", "ggx+lambert+dielectric+coupled"])
def test_defaults_of_every_schema_load(tmp_path, spec):
    result = valid_result(spec)
    assert FitResult.load(result.save(tmp_path / "r.json")) == result


def test_bounds_have_a_tiny_tolerance_only(tmp_path):
    low = parameter_schema(parse_model(SPEC))[1].lower           # roughness floor
    for roughness in (low, 1.0, 1.0 + 1e-9, float(np.float32(low))):
        data = json.loads(_edit(_set("parameters", "roughness", roughness)))
        assert FitResult.from_dict(data).parameters["roughness"] == roughness
    aniso = valid_result("ggx_aniso+lambert")
    aniso.parameters["rotation"] = float(np.float32(math.pi / 2))  # a float32 fit at the edge
    assert FitResult.from_dict(aniso.to_dict()) == aniso
    for roughness in (1.001, low * 0.99):
        with pytest.raises(ResultFileError, match="bounds"):
            FitResult.from_dict(json.loads(_edit(_set("parameters", "roughness", roughness))), source="x")


def test_hand_written_result_without_optional_fields_loads(tmp_path):
    """optimizer, provenance and toolkit_version may be absent (the renderer's tests write such files)."""
    path = tmp_path / "minimal.json"
    params = valid_result().parameters
    path.write_text(json.dumps({"spec": SPEC, "parameters": params, "errors": {}, "schema_version": 1}))
    result = FitResult.load(path)
    assert result.parameters == params and result.provenance == {} and result.optimizer == {}
    assert result.material == "material"


def test_utf8_bom_and_integers_are_fine(tmp_path):
    path = tmp_path / "bom.json"
    path.write_bytes(b"\xef\xbb\xbf" + _edit(_set("parameters", "albedo", [1, 0, 0])).encode())
    assert FitResult.load(path).parameters["albedo"] == [1, 0, 0]


# --- writers refuse non-finite numbers ---------------------------------------------------

@pytest.mark.parametrize("where", ["parameter", "error", "optimizer"])
def test_save_refuses_nan_and_writes_nothing(tmp_path, where):
    result = valid_result()
    if where == "parameter":
        result.parameters["albedo"] = [0.5, float("nan"), 0.5]
        expected = r"parameters\.albedo\[1\] is NaN"
    elif where == "error":
        result.errors["m1"] = float("inf")
        expected = r"errors\.m1 is Infinity"
    else:
        result.optimizer["runs"][0]["loss"] = float("-inf")
        expected = r"optimizer\.runs\[0\]\.loss is -Infinity"
    with pytest.raises(ValueError, match=expected):
        result.save(tmp_path / "r.json")
    assert not (tmp_path / "r.json").exists()
    assert list(tmp_path.iterdir()) == []


def test_from_dict_refuses_what_load_refuses():
    data = valid_result().to_dict()
    data["parameters"]["roughness"] = float("nan")
    with pytest.raises(ResultFileError, match="^<dict>: parameters.roughness is NaN"):
        FitResult.from_dict(data)


@pytest.mark.parametrize("suffix", [".gltf", ".glb"])
def test_gltf_writer_refuses_non_finite_numbers(tmp_path, suffix):
    doc = {"asset": {"version": "2.0"}, "buffers": [{"byteLength": 0}],
           "materials": [{"pbrMetallicRoughness": {"roughnessFactor": float("nan")}}]}
    out = tmp_path / f"m{suffix}"
    with pytest.raises(ExportError, match=r"materials\[0\]\.pbrMetallicRoughness\.roughnessFactor would be NaN"):
        write_gltf_file(out, doc, b"")
    assert not out.exists()


# --- report folders, valid results through the commands ------------------------------------

def test_report_folder_skips_non_results_silently_and_warns_about_broken_ones(tmp_path, capsys):
    good = valid_result().save(tmp_path / "good.json")
    (tmp_path / "summary.json").write_text(json.dumps({"not": "a fit result"}))
    (tmp_path / "broken.json").write_text(_token(["parameters", "roughness"], "NaN"))
    found = collect_results([tmp_path])
    assert [p for p, _ in found] == [good]
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("brdf-fit report: warning: ") and "broken.json" in err[0]
    with pytest.raises(NotAResultError):
        collect_results([tmp_path / "summary.json"])


def test_valid_result_exports_and_evaluates(tmp_path, capsys, directions):
    path = valid_result().save(tmp_path / "good.json")
    out = tmp_path / "m.gltf"
    assert main(["export", str(path), "--out", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] == pytest.approx(0.5)
    assert main(["eval", str(path), str(directions), str(tmp_path / "v.npy")]) == 0
    values = np.load(tmp_path / "v.npy")
    assert values.shape == (2, 3) and np.all(np.isfinite(values)) and np.all(values > 0)
    assert "error" not in capsys.readouterr().err
