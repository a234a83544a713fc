"""What a model file can do wrong (issue 60): each mistake is one ``brdf-fit CMD: error:``
line naming the model file (and the parameter, where one is involved), exit 2, never a
traceback; what a model file prints never reaches stdout; two files declaring one name are
refused.  Each model file is a few lines this test writes; most mistakes are caught when the
file is loaded (brdf/own_guard.py: ``check``), before any table is read, so the corpus below
runs in seconds.  The few that happen during a fit use a small synthetic table (a Lambertian
of albedo 0.7, 12 x 12 x 24 pairs)."""

import json

import pytest

from brdf import own
from brdf_fit.cli import main

HEAD = '''
import jax
import jax.numpy as jnp
from brdf.own import OwnModel, Param, Start

def lam(p, wi, wo):
    return jnp.broadcast_to(p["a"] / jnp.pi, wi.shape)

A = Param("a", 3, 0.0, 1.0, 0.5, "albedo")
'''

# name -> (the file's body after HEAD, what the one error line holds besides the file's name)
CORPUS = {
    "rule_raises": ('M = OwnModel("mine", (Param("a", 3, 0.0, 1.0, 0.5, "albedo", start=Start(rule=lambda e: 1 / 0)),), '
                    'lam)', "own:mine: the start rule of parameter 'a' raised ZeroDivisionError"),
    "rule_nan": ('M = OwnModel("mine", (Param("a", 3, 0.0, 1.0, 0.5, "albedo", '
                 'start=Start(rule=lambda e: float("nan"))),), lam)', "the start rule of parameter 'a' returned nan"),
    "raises_for_some_values": ('''
def f(p, wi, wo):
    def refuse(a):
        if float(a.max()) > 0.9:
            raise ValueError("albedo above 0.9")
    jax.debug.callback(refuse, p["a"])
    return lam(p, wi, wo)
M = OwnModel("mine", (A,), f)''', "evaluate at a = 1 (its upper bound) raised ValueError: albedo above 0.9 (in a JAX "
                                  "callback)"),
    "no_derivative": ('''
def f(p, wi, wo):
    a = jax.pure_callback(lambda x: x, jax.ShapeDtypeStruct(p["a"].shape, p["a"].dtype), p["a"])
    return jnp.broadcast_to(a / jnp.pi, wi.shape)
M = OwnModel("mine", (A,), f)''', "own:mine: evaluate raised ValueError: Pure callbacks do "
                                  "not support JVP"),
    "complex": ('M = OwnModel("mine", (A,), lambda p, wi, wo: lam(p, wi, wo) * (1 + 0j))',
                "evaluate returned complex values"),
    "numpy": ('import numpy as np\nM = OwnModel("mine", (A,), lambda p, wi, wo: np.asarray(lam(p, wi, wo)))',
              "evaluate raised TracerArrayConversionError"),
    "shape_written_in": ('M = OwnModel("mine", (A,), lambda p, wi, wo: jnp.ones((4, 3)) * p["a"] / jnp.pi)',
                         "evaluate returned shape (4, 3) for 7 direction pairs"),
    "integers": ('M = OwnModel("mine", (A,), lambda p, wi, wo: jnp.ones(wi.shape, jnp.int32))',
                 "evaluate returned int32 values"),
    "exit_0": ("import sys\nsys.exit(0)", "importing it called sys.exit(0)"),
    "exit_text": ('import sys\nsys.exit("bye")', "importing it called sys.exit('bye')"),
    "os_exit": ("import os\nos._exit(0)", "importing it called os._exit(0)"),
    "os_exit_in_evaluate": ('import os\nM = OwnModel("mine", (A,), lambda p, wi, wo: os._exit(4))',
                            "own:mine: evaluate called os._exit(4)"),
    "exit_in_evaluate": ('import sys\nM = OwnModel("mine", (A,), lambda p, wi, wo: sys.exit(3))',
                         "own:mine: evaluate called sys.exit(3)"),
    "nan_at_a_bound": ('K = Param("k", 1, 0.0, 10.0, 1.0, "k")\n'
                       'M = OwnModel("mine", (A, K), lambda p, wi, wo: lam(p, wi, wo) / (10.0 - p["k"]) * 0.0)',
                       "evaluate is NaN at k = 10 (its upper bound"),
    "huge_bounds": ('M = OwnModel("mine", (A, Param("k", 1, -1e300, 1e300, 1.0, "k")), lambda p, wi, wo: lam(p, wi, wo))',
                    "parameter 'k' has bounds [-1e+300, 1e+300] beyond +-1e+30"),
    "scan_outside": ('M = OwnModel("mine", (A, Param("k", 1, 0.0, 10.0, 1.0, "k", start=Start(scan=(1.0, 20.0)))), '
                     'lambda p, wi, wo: lam(p, wi, wo))', "parameter 'k': Start(scan=(1.0, 20.0)) needs finite values "
                                                          "within its bounds [0, 10]"),
    "text_bound": ('M = OwnModel("mine", (A, Param("k", 1, "0", 10.0, 1.0, "k")), lambda p, wi, wo: lam(p, wi, wo))',
                   "parameter 'k' needs finite numbers for its bounds and default, found ['0', 10.0] and 1.0"),
    "log_scale_at_zero": ('M = OwnModel("mine", (A, Param("k", 1, 0.0, 10.0, 1.0, "k", scale="log")), lambda p, wi, wo: '
                          'lam(p, wi, wo))', "parameter 'k': scale='log' must be 'linear' or 'log', and 'log' needs a "
                                             "positive lower bound (found [0, 10]) and no period"),
    "infinite_bound": ('M = OwnModel("mine", (A, Param("k", 1, 0.0, float("inf"), 1.0, "k")), lambda p, wi, wo: '
                       'lam(p, wi, wo))', "parameter 'k' needs finite numbers for its bounds and default"),
}


@pytest.mark.parametrize("case", sorted(CORPUS))
def test_a_mistake_is_one_line_naming_the_file_and_exit_2(tmp_path, monkeypatch, capsys, case):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(own, "_REGISTRY", {})
    body, message = CORPUS[case]
    (tmp_path / f"{case}.py").write_text(HEAD + body + "\n")
    model = "M" if "exit(" not in body or "evaluate" in message else "ANY"
    assert main(["fit", "nothing.binary", "--model", f"{case}.py:{model}", "--json"]) == 2
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert out == "" and len(lines) == 1, err
    assert lines[0].startswith(f"brdf-fit fit: error: {case}.py: ") and message in lines[0], lines[0]
    assert "Traceback" not in err


def test_a_folder_given_as_the_model_file(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "models.py").mkdir()
    assert main(["fit", "nothing.binary", "--model-file", "models.py"]) == 2
    assert capsys.readouterr().err.strip() == ("brdf-fit fit: error: models.py: is a folder, not a model file "
                                               "(give the Python file: PATH.py)")

# A model whose jax.debug.callback raises at the table's grazing pairs only: the load check's
# pairs pass, the fit fails.
CALLBACK_RAISES = HEAD + '''
def f(p, wi, wo):
    def refuse(z):
        if float(z.min()) < 0.3:
            raise ValueError("grazing pairs")
    jax.debug.callback(refuse, wi[..., 2])
    return lam(p, wi, wo)
M = OwnModel("mine", (A,), f)
'''


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    """A small samples table of a Lambertian of albedo 0.7."""
    import jax.numpy as jnp

    from data_loaders import write_samples
    from fitting.synthetic import synthetic_measured
    model = own.OwnModel("lambert_table", (own.Param("a", 3, 0.0, 1.0, 0.5, "albedo"),),
                         lambda p, wi, wo: jnp.broadcast_to(p["a"] / jnp.pi, wi.shape))
    m = synthetic_measured(model, {"a": [0.7, 0.7, 0.7]}, grid=(12, 12, 24, 1))
    path = tmp_path_factory.mktemp("table") / "t.npz"
    write_samples(path, m.wi[m.valid], m.wo[m.valid], m.values[m.valid], weights=m.weights[m.valid],
                  material="t", isotropic=True)
    return path


def _fit(tmp_path, table, models, *extra):
    return main(["fit", str(table), "--model", models, "--samples", "2000", "--out", str(tmp_path / "out"),
                 *extra])


def test_nan_on_measured_pairs_names_the_file_and_the_parameters(table, tmp_path, monkeypatch, capsys):
    """Finite at the check's pairs and bounds, NaN at the table's pairs below 0.3 of cos theta_i."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "grazing.py").write_text(HEAD + 'M = OwnModel("mine", (A, Param("k", 1, 0.5, 2.0, 1.0, "k")), '
                                         'lambda p, wi, wo: lam(p, wi, wo) * p["k"] * '
                                         'jnp.where(wi[..., 2:] < 0.3, jnp.nan, 1.0))\n')
    assert _fit(tmp_path, table, "grazing.py:M") == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert "the fit of own:mine (model file grazing.py) ended with non-finite errors at a = [" in err
    assert "k = " in err and "its evaluate is NaN or infinite at some measured direction pairs" in err


def test_a_library_whose_own_model_fails_on_a_table_exits_2(table, tmp_path, monkeypatch, capsys):
    """The library is written with the other model, and says the fit failed (exit 2, as batch)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "grazing.py").write_text(HEAD + 'M = OwnModel("mine", (A,), lambda p, wi, wo: lam(p, wi, wo) * '
                                         'jnp.where(wi[..., 2:] < 0.3, jnp.nan, 1.0))\n')
    code = main(["library", str(table), "--models", "ggx+lambert,grazing.py:M", "--out", str(tmp_path / "lib"),
                 "--samples", "2000", "--starts", "1", "--jobs", "1"])
    out = capsys.readouterr().out
    assert code == 2
    assert "library of 1 materials" in out and "1 input(s) with a failed fit" in out
    assert (tmp_path / "lib" / "materials.glb").stat().st_size > 0


def test_an_exception_during_the_fit_names_the_file(table, tmp_path, monkeypatch, capsys):
    """A callback that raises only at the table's grazing pairs: at the fit, not at the check."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "cb.py").write_text(CALLBACK_RAISES)
    assert _fit(tmp_path, table, "cb.py:M") == 2
    err = capsys.readouterr().err.strip()
    assert err == "brdf-fit fit: error: cb.py: own:mine: its fit failed: ValueError: grazing pairs (in a JAX callback)"


def test_what_a_model_file_prints_goes_to_stderr(table, tmp_path, monkeypatch, capsys):
    """Prints at import and in evaluate (while traced) and jax.debug.print (while the fit runs):
    --json's stdout stays one JSON document."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "chatty.py").write_text(HEAD + '''
print("hello at import")
def f(p, wi, wo):
    print("hello from evaluate")
    jax.debug.print("hello from the device {x}", x=p["a"][0])
    return lam(p, wi, wo)
M = OwnModel("mine", (A,), f)
''')
    assert _fit(tmp_path, table, "chatty.py:M", "--json") == 0
    out, err = capsys.readouterr()
    document = json.loads(out)
    assert [r["spec"] for r in document["results"]] == ["own:mine"]
    assert "hello at import" in err and "hello from evaluate" in err and "hello from the device" in err


def test_two_files_declaring_one_name_are_refused(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    body = 'M = OwnModel("mine", (A,), lambda p, wi, wo: lam(p, wi, wo) * {})\n'
    (tmp_path / "one.py").write_text(HEAD + body.format(1.0))
    (tmp_path / "two.py").write_text(HEAD + body.format(0.5))
    for argv in (["--model", "one.py:M,two.py:M"], ["--model", "one.py:M", "--model-file", "two.py"]):
        assert main(["fit", "nothing.binary", *argv]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "own:mine is declared in two model files" in err
        assert "one.py" in err and "two.py" in err
    (tmp_path / "both.py").write_text(HEAD + body.format(1.0) + body.format(0.5).replace("M =", "N ="))
    assert main(["fit", "nothing.binary", "--model-file", "both.py"]) == 2
    assert capsys.readouterr().err.strip() == ("brdf-fit fit: error: both.py: M and N both declare own:mine: rename "
                                               "one of the models")
    (tmp_path / "copy").mkdir()         # the same bytes in two places: one model, not refused
    (tmp_path / "copy" / "one.py").write_text(HEAD + body.format(1.0))
    assert main(["models", "--model-file", "one.py", "--model-file", "copy/one.py"]) == 0


def test_a_path_with_a_comma_is_one_item_when_the_file_exists(table, tmp_path, monkeypatch, capsys):
    """brdf_fit/own_models.py: split_models; a comma in a path that does not exist splits."""
    from brdf_fit.own_models import split_models
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a,b").mkdir()
    (tmp_path / "a,b" / "m.py").write_text(HEAD + 'M = OwnModel("mine", (A,), lam)\n')
    assert split_models("ggx+lambert,a,b/m.py:M,lambert") == ["ggx+lambert", "a,b/m.py:M", "lambert"]
    assert split_models("ggx+lambert,c,d/m.py:M") == ["ggx+lambert", "c", "d/m.py:M"]
    assert _fit(tmp_path, table, "a,b/m.py:M", "--json") == 0
    document = json.loads(capsys.readouterr().out)
    assert document["results"][0]["model_file"]["name"] == "m.py"


GLSL = '''
P = (Param("rho", 3, 0.0, 1.0, 0.5, "albedo"),)
def lambert(p, wi, wo):
    return jnp.broadcast_to(p["rho"] / jnp.pi, wi.shape)
SYNTAX = OwnModel("syntax_error", P, lambert, glsl="""
vec3 own_brdf(BrdfParams p, vec3 wi, vec3 wo) {
    return p.rho / PI
}
""")
MEMBER = OwnModel("member", P, lambert, glsl="vec3 own_brdf(BrdfParams p, vec3 wi, vec3 wo) { return p.albedo; }")
VERSION = OwnModel("version", P, lambert, glsl="#version 330\\nvec3 own_brdf(BrdfParams p, vec3 wi, vec3 wo) { return p.rho; }")
REDEFINED = OwnModel("redefined", P, lambert, glsl="float dot3(vec3 a, vec3 b) { return 0.0; }\\n"
                     "vec3 own_brdf(BrdfParams p, vec3 wi, vec3 wo) { return p.rho; }")
'''


@pytest.mark.parametrize("name, message", [
    ("SYNTAX", "glsl.py: syntax_error: its glsl does not compile: line 4 of its glsl: error: syntax error"),
    ("MEMBER", "glsl.py: member: its glsl does not compile: line 1 of its glsl: error:"),
    ("VERSION", "glsl.py: version: its glsl does not compile: line 1 of its glsl: preprocessor error: #version"),
    ("REDEFINED", "glsl.py: redefined: its glsl does not compile: line 1 of its glsl: error: function `dot3' redefined"),
])
def test_a_glsl_twin_that_does_not_compile_is_refused_before_the_fit(tmp_path, monkeypatch, capsys, name, message):
    """brdf_fit/own_models.py: check_glsl, before the table is even read."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "glsl.py").write_text(HEAD + GLSL)
    assert main(["fit", "nothing.binary", "--model", f"ggx+lambert,glsl.py:{name}"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith(f"brdf-fit fit: error: {message}"), err


def test_a_report_keeps_the_other_spheres_and_exits_2(table, tmp_path, monkeypatch, capsys):
    """A result of a model whose glsl= does not compile (fitted in Python, where nothing compiles
    it) beside ggx+lambert's: the report is written, ggx+lambert's lit sphere drawn, one error
    line names the model file, exit 2."""
    from data_loaders import load
    from fitting.fit import fit
    monkeypatch.chdir(tmp_path)
    (tmp_path / "glsl.py").write_text(HEAD + GLSL)
    model = own.load_file(tmp_path / "glsl.py", "SYNTAX")
    fit(load(table), model, samples=2000).save(tmp_path / "out" / "t.own:syntax_error.json")
    assert _fit(tmp_path, table, "ggx+lambert") == 0
    capsys.readouterr()
    assert main(["report", str(tmp_path / "out"), "--model-file", "glsl.py", "--measured", str(table),
                 "--out", str(tmp_path / "report")]) == 2
    err = capsys.readouterr().err
    errors = [line for line in err.splitlines() if "error:" in line]
    assert len(errors) == 1 and "Traceback" not in err
    assert errors[0].startswith("brdf-fit report: error: glsl.py: syntax_error: its glsl does not compile")
    assert errors[0].endswith("the report is written without its lit sphere")
    page = (tmp_path / "report" / "t.html").read_text()
    assert [p.name for p in (tmp_path / "report").glob("*-render-*.png")] == ["t-render-ggx_lambert.png"]
    assert "t-render-ggx_lambert.png" in page and "syntax_error: its glsl does not compile" in page


@pytest.mark.parametrize("named", ["/elsewhere/evil.py", "evil.py; rm -rf ~", "\x1b[31mred.py\u202e"])
def test_a_model_file_named_by_a_result_is_data_never_a_command(table, tmp_path, monkeypatch, capsys, named):
    """brdf/own.py: check_source quotes the name the result holds (repr: escapes shown) and tells
    the user to give their own copy as --model-file PATH.py, never the result's path."""
    from data_loaders import load
    from fitting.fit import fit
    monkeypatch.chdir(tmp_path)
    (tmp_path / "good.py").write_text(HEAD + 'M = OwnModel("mine", (A,), lam)\n')
    path = fit(load(table), own.load_file(tmp_path / "good.py", "M"), samples=2000).save(tmp_path / "r.json")
    data = json.loads(path.read_text())
    data["model_file"]["name"] = named
    path.write_text(json.dumps(data))
    monkeypatch.setattr(own, "_REGISTRY", {})
    assert main(["report", str(path), "--out", str(tmp_path / "report")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "\x1b" not in err and "\u202e" not in err
    assert f"the result says its model file was {named!r} (sha256 " in err      # repr: escapes shown
    assert f"--model-file {named}" not in err and "give your copy of that model file with --model-file PATH.py" in err


def test_an_own_model_failing_in_a_fit_leaves_the_others_written(table, tmp_path, monkeypatch, capsys):
    """fit --model own,ggx+lambert with the own model failing during its fit (a callback that
    raises at the table's grazing pairs): ggx+lambert is fitted, written and in --json's
    document; the one error line names the file; exit 2."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "cb.py").write_text(CALLBACK_RAISES)
    assert _fit(tmp_path, table, "cb.py:M,ggx+lambert", "--json") == 2
    out, err = capsys.readouterr()
    document = json.loads(out)
    assert [r["spec"] for r in document["results"]] == ["ggx+lambert"]
    assert document["failed"] == [{"model": "own:mine", "error": "cb.py: own:mine: its fit failed: ValueError: "
                                                                 "grazing pairs (in a JAX callback)"}]
    assert (tmp_path / "out" / "t.ggx+lambert.json").is_file()
    assert err.strip().splitlines()[-1] == ("brdf-fit fit: error: cb.py: own:mine: its fit failed: ValueError: "
                                            "grazing pairs (in a JAX callback); the other models' results are "
                                            "written")


def test_a_start_inside_the_bounds_is_taken_as_declared():
    """fitting/transforms.py: from_params keeps an own model's start inside its bounds (before:
    moved to 0.25 % of the range, 25 000 in [0, 1e7]); one on a bound is moved 0.25 % inside,
    as for the toolkit's models, whose starts are unchanged."""
    import jax.numpy as jnp
    import numpy as np

    from brdf.model import parameter_schema, parse_model
    from fitting.transforms import from_params, to_values
    model = own.OwnModel("wide", (own.Param("a", 3, 0.0, 1.0, 0.0, "albedo"), own.Param("b", 1, 0.0, 1e7, 100.0, "b")),
                         lambda p, wi, wo: jnp.broadcast_to(p["a"] / jnp.pi, wi.shape) * (1.0 + p["b"] * 1e-7))
    spec = parse_model(model)
    back = to_values(spec, from_params(spec, {"a": [0.0, 0.3, 1.0], "b": 100.0}))
    np.testing.assert_allclose(back["b"], 100.0, rtol=1e-9)
    np.testing.assert_allclose(back["a"], [0.0025, 0.3, 0.9975], rtol=1e-9)     # on a bound: 0.25 % inside
    ggx = parse_model("ggx+lambert")
    r = next(p for p in parameter_schema(ggx) if p.name == "roughness")
    inside = r.lower + 0.001 * (r.upper - r.lower)       # the toolkit's models: nudged as before
    assert to_values(ggx, from_params(ggx, {"albedo": [0.3] * 3, "roughness": inside, "f0": [0.04] * 3}))[
        "roughness"] == pytest.approx(r.lower + 0.0025 * (r.upper - r.lower), rel=1e-9)


def test_the_guard_restores_stdout_when_two_threads_interleave():
    """brdf/own_guard.py: held() in two threads, entered A, B and left A, B (two own models'
    fits in FIT_THREADS): stdout is stderr while either runs, and both are restored after."""
    import logging
    import sys
    import threading

    from brdf.own_guard import _CALLBACK_LOGGER, held
    before, logger = sys.stdout, logging.getLogger(_CALLBACK_LOGGER)
    disabled = logger.disabled
    a_in, b_in, a_out = threading.Event(), threading.Event(), threading.Event()
    seen = []

    def a():
        with held():
            a_in.set()
            b_in.wait(5)
            seen.append(sys.stdout is sys.stderr)
        a_out.set()

    def b():
        a_in.wait(5)
        with held():
            b_in.set()
            a_out.wait(5)
            seen.append(sys.stdout is sys.stderr and logger.disabled)
    threads = [threading.Thread(target=a), threading.Thread(target=b)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10)
    assert seen == [True, True]
    assert sys.stdout is before and logger.disabled == disabled


def test_a_loop_at_import_is_stopped(tmp_path, monkeypatch, capsys):
    """brdf/own_guard.py: import_deadline (MAX_IMPORT_SECONDS, 60 s; 0.5 s here)."""
    import signal
    import time

    from brdf import own_guard
    if signal.getsignal(signal.SIGALRM) not in (signal.SIG_DFL, None):
        pytest.skip("SIGALRM is in use here (a test timeout plugin): no import deadline")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(own_guard, "MAX_IMPORT_SECONDS", 0.5)
    (tmp_path / "loop.py").write_text("while True:\n    try:\n        pass\n    except Exception:\n        pass\n")
    t = time.perf_counter()
    assert main(["fit", "nothing.binary", "--model", "loop.py:M"]) == 2
    assert time.perf_counter() - t < 10
    assert capsys.readouterr().err.strip() == ("brdf-fit fit: error: loop.py: importing it ran for more than 0.5 s "
                                               "(a loop at import?); it was stopped")


def test_eval_of_a_result_whose_function_fails_there_is_one_line(table, tmp_path, monkeypatch, capsys):
    """eval at a direction where the model's callback raises (wi.x = 0.123456, which neither the
    table nor the image error's sphere has): one line naming the file, exit 2 (before: an
    internal error, exit 1)."""
    import numpy as np
    monkeypatch.chdir(tmp_path)
    (tmp_path / "graze.py").write_text(HEAD + '''
def f(p, wi, wo):
    def refuse(x):
        if abs(x - 0.123456).min() < 1e-9:
            raise ValueError("not at wi.x = 0.123456")
    jax.debug.callback(refuse, wi[..., 0])
    return lam(p, wi, wo)
M = OwnModel("mine", (A,), f)
''')
    assert _fit(tmp_path, table, "graze.py:M") == 0
    np.save(tmp_path / "d.npy", np.array([[0.123456, 0.0, np.sqrt(1 - 0.123456 ** 2), 0.0, 0.0, 1.0]]))
    capsys.readouterr()
    assert main(["eval", str(tmp_path / "out" / "t.own:mine.json"), "d.npy", "o.npy", "--model-file", "graze.py"]) == 2
    assert capsys.readouterr().err.strip() == ("brdf-fit eval: error: graze.py: own:mine: its evaluation failed: "
                                               "ValueError: not at wi.x = 0.123456 (in a JAX callback)")
    assert not (tmp_path / "o.npy").exists()
