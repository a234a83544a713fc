"""The command line as a user meets it: help with defaults, --json documents, -q / -v,
the result schema (checked against real results with the jsonschema package),
timestamps and parameters flagged at their bounds."""

import argparse
import datetime
import json

import numpy as np
import pytest

from data_loaders import write_samples
from brdf_fit.cli import build_parser, main
from fitting.result import FitResult
from fitting.synthetic import synthetic_measured

TRUTH = {"albedo": [0.4, 0.25, 0.1], "roughness": 0.45, "f0": [0.05, 0.05, 0.05]}
FAST = ["--samples", "2000", "--starts", "1"]


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    path = tmp_path_factory.mktemp("usability") / "mat.npz"
    m = synthetic_measured("ggx+lambert", TRUTH, grid=(12, 12, 24, 1))
    write_samples(path, m.wi[m.valid], m.wo[m.valid], m.values[m.valid], weights=m.weights[m.valid],
                  material="mat", isotropic=True)
    return path


def _subparsers():
    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return action.choices


def test_every_option_has_help_and_its_default_is_shown():
    for name, sub in _subparsers().items():
        text = sub.format_help()
        for action in sub._actions:
            if action.help == argparse.SUPPRESS:
                continue
            assert action.help, (name, action.dest)
            # ``is``: a default of 0 (--seed) equals False and is shown all the same
            if action.option_strings and action.default is not None and action.default is not False \
                    and action.dest != "help":
                assert f"(default: {action.default})" in " ".join(text.split()), (name, action.dest)


def test_top_level_help_lists_every_exit_code():
    """Every exit code brdf_fit.errors defines is in the help's epilog."""
    from brdf_fit import errors
    text = " ".join(build_parser().format_help().split())
    codes = {errors.OK, errors.FAILED, errors.BAD_INPUT, errors.NO_GL, errors.INTERRUPTED, errors.TERMINATED}
    for code in codes:
        assert f" {code} " in text, code


@pytest.mark.parametrize("argv", [["--help"], ["fit", "--help"], ["batch", "--help"], ["info", "TABLE"]])
def test_help_and_info_import_no_jax(table, argv):
    """Help and ``info`` answer without importing JAX (or the models, or the fitter)."""
    import subprocess
    import sys
    code = ("import sys\nfrom brdf_fit.cli import main\ntry:\n    main(sys.argv[1:])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in ('jax', 'brdf', 'fitting.fit', 'nlopt') if m in sys.modules), file=sys.stderr)")
    argv = [str(table) if a == "TABLE" else a for a in argv]
    res = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=120)
    assert res.stderr.strip().splitlines()[-1] == "[]", res.stderr
    assert res.stdout.strip()


@pytest.mark.parametrize("argv", [["models"], ["models", "--json"], ["schema"]])
def test_models_and_schema_import_no_jax(argv, capsys):
    """``models`` and ``schema`` read the declarations without importing JAX (brdf's
    formulas import it on first use: brdf/_lazy.py), and print the same as in a
    process where JAX is imported (this one: conftest imports it)."""
    import subprocess
    import sys
    import jax  # noqa: F401 -- the comparison below runs with JAX imported, whatever conftest does
    code = ("import sys\nfrom brdf_fit.cli import main\nstatus = main(sys.argv[1:])\n"
            "print(status, sorted(m for m in ('jax', 'jaxlib', 'fitting.fit', 'nlopt') if m in sys.modules), "
            "file=sys.stderr)")
    res = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=120)
    assert res.stderr.strip().splitlines()[-1] == "0 []", res.stderr
    assert main(argv) == 0
    assert res.stdout == capsys.readouterr().out
    if argv == ["schema"]:
        from fitting.result_schema import result_schema
        assert json.loads(res.stdout) == result_schema()
    else:
        assert "ggx+lambert" in res.stdout


def test_json_documents_on_stdout(table, tmp_path, capsys):
    assert main(["models", "--json"]) == 0
    models = json.loads(capsys.readouterr().out)
    assert "ggx+lambert" in models["examples"] and len(models["auto"]) == 24

    assert main(["info", str(table), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["format"] == "npz" and info["material"] == "mat" and info["valid"] == info["samples"] > 0

    assert main(["fit", str(table), "--model", "ggx+lambert,ggx+burley", "--out", str(tmp_path / "f"),
                 "--json", *FAST]) == 0
    fitted = json.loads(capsys.readouterr().out)
    assert [r["spec"] for r in fitted["results"]] == sorted(
        ["ggx+lambert", "ggx+burley"], key=lambda s: [r["errors"]["m1"] for r in fitted["results"]
                                                       if r["spec"] == s][0])
    for r in fitted["results"]:
        assert FitResult.load(r["path"]).errors["m1"] == r["errors"]["m1"]

    result = fitted["results"][0]["path"]
    assert main(["export", result, "--out", str(tmp_path / "m.glb"), "--json"]) == 0
    exported = json.loads(capsys.readouterr().out)
    assert exported["path"] == str(tmp_path / "m.glb") and (tmp_path / "m.glb").stat().st_size > 0
    assert exported["honesty"]["m1_fitted_model"] == pytest.approx(fitted["results"][0]["errors"]["m1"],
                                                                   rel=1e-6)

    assert main(["batch", str(table), "--out", str(tmp_path / "b"), "--json", *FAST]) == 0
    batch = json.loads(capsys.readouterr().out)
    assert batch["done"] == 1 and batch["failed"] == 0 and batch["rows"][0]["status"] == "fitted"


def test_quiet_and_verbose(table, tmp_path, capsys):
    main(["fit", str(table), "--model", "ggx+lambert,ggx+burley", "--out", str(tmp_path), *FAST])
    normal = capsys.readouterr().err
    assert "2/2 models" in normal and "\r" not in normal      # plain progress lines off a terminal
    main(["fit", str(table), "--model", "ggx+lambert,ggx+burley", "--out", str(tmp_path), "-q", *FAST])
    assert capsys.readouterr().err == ""
    main(["fit", str(table), "--out", str(tmp_path), "-v", *FAST])
    assert "preparing" in capsys.readouterr().err


def test_result_schema_documents_and_validates_real_results(table, tmp_path, capsys):
    jsonschema = pytest.importorskip("jsonschema")
    assert main(["schema"]) == 0
    schema = json.loads(capsys.readouterr().out)
    jsonschema.Draft202012Validator.check_schema(schema)
    main(["fit", str(table), "--model", "ggx+lambert+clearcoat,gltf+specular",
          "--out", str(tmp_path), *FAST])
    for path in tmp_path.glob("*.json"):
        data = json.loads(path.read_text())
        jsonschema.validate(data, schema)

        def documented(value, node, where):
            for key, sub in value.items():
                assert key in node["properties"], f"{where}.{key} is not in the schema"
                assert node["properties"][key].get("description"), f"{where}.{key} has no description"
                if isinstance(sub, dict) and "properties" in node["properties"][key] and key != "options":
                    documented(sub, node["properties"][key], f"{where}.{key}")
        documented(data, schema, path.name)
    broken = dict(data, parameters=dict(data["parameters"], roughness="rough"))
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(broken, schema)


def test_results_carry_a_utc_timestamp_and_flag_parameters_at_bounds(table, tmp_path, capsys):
    before = datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0)
    main(["fit", str(table), "--out", str(tmp_path), *FAST])
    capsys.readouterr()
    result = FitResult.load(tmp_path / "mat.ggx+lambert.json")
    created = datetime.datetime.strptime(result.created, "%Y-%m-%dT%H:%M:%SZ").replace(
        tzinfo=datetime.timezone.utc)
    assert before <= created <= datetime.datetime.now(datetime.timezone.utc)
    assert result.at_bounds() == {}                     # roughness 0.45, colours inside
    result.parameters["roughness"] = 0.995              # within 1 % of the upper bound 1
    result.parameters["f0"] = [0.005, 0.2, 0.3]         # one channel within 1 % of 0
    assert result.at_bounds() == {"roughness": "upper", "f0": "lower"}
    assert json.loads(result.to_json())["at_bounds"] == {"roughness": "upper", "f0": "lower"}
    path = result.save(tmp_path / "flagged.json")
    from brdf_fit.commands import print_table
    import io
    out = io.StringIO()
    print_table([FitResult.load(path)], stream=out)
    text = out.getvalue()
    assert "roughness=0.995*" in text and "f0=(0.005, 0.2, 0.3)*" in text and "within 1 %" in text
    np.testing.assert_allclose(FitResult.load(path).parameters["roughness"], 0.995)


def test_render_falls_back_to_the_provenance_file(table, tmp_path, capsys):
    from PIL import Image
    from shaders.gl import gl_available
    ok, reason = gl_available()
    if not ok:
        pytest.skip(f"no OpenGL: {reason}")
    main(["fit", str(table), "--out", str(tmp_path), *FAST])
    result = tmp_path / "mat.ggx+lambert.json"
    assert main(["render", str(result), "--size", "128", "--out", str(tmp_path / "a.png")]) == 0
    assert "from the result's provenance" in capsys.readouterr().err
    compared = Image.open(tmp_path / "a.png").size
    moved = FitResult.load(result)
    moved.provenance["file"] = str(tmp_path / "gone.npz")
    moved.save(tmp_path / "moved.json")
    assert main(["render", str(tmp_path / "moved.json"), "--size", "128", "--out", str(tmp_path / "b.png")]) == 0
    assert "is not here" in capsys.readouterr().err
    alone = Image.open(tmp_path / "b.png").size
    # measured | fitted | difference: three panels of the single render's size, narrow gaps, and
    # the titles and colour bar above and below
    assert 3 * alone[0] <= compared[0] < 3 * alone[0] + 32 and compared[1] > alone[1]
