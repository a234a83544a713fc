"""A first fit says what it is doing before it compiles, and its progress estimate
leaves out the first model's compiling (issue 62: nothing on the terminal for 220 s,
then an ETA of 5074 s for a fit that ended at 281 s)."""

import io
import sys

import pytest

from brdf_fit import progress as progress_module
from brdf_fit.cli import main
from brdf_fit.progress import Progress

from test_fitting_cli import write_sample_file


class _Clock:
    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


def test_the_estimate_leaves_out_the_first_step(monkeypatch):
    """Ten steps, the first 200 s (compiling), the others 2 s: after the second step
    8 remain at 2 s = 16 s, not (202 / 2) x 8 = 808 s; after the first, no estimate."""
    clock = _Clock()
    monkeypatch.setattr(progress_module.time, "perf_counter", clock)
    stream = io.StringIO()
    bar = Progress(10, "models", stream=stream)
    clock.now = 200.0
    bar.step("first")
    clock.now = 202.0
    bar.step("second")
    clock.now = 204.0
    bar.step("third")
    first, second, third = stream.getvalue().splitlines()
    assert "ETA" not in first and first.startswith("[1/10 models  200.0s elapsed]")
    assert "ETA 16s" in second
    assert "ETA 14s" in third
    for _ in range(7):
        clock.now += 2.0
        bar.step()
    assert "ETA" not in stream.getvalue().splitlines()[-1]      # nothing left


@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    return write_sample_file(tmp_path_factory.mktemp("first") / "first_run.npz", "first_run")


def _terminal(monkeypatch):
    """stderr as a terminal (the announcement is for one; a script's stderr gets errors only)."""
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)


def test_not_on_a_terminal_nothing_is_announced(tmp_path, sample, monkeypatch, capsys):
    monkeypatch.setenv("BRDF_JAX_CACHE", str(tmp_path / "empty-cache"))
    assert main(["fit", str(sample), "--model", "ggx+lambert", "--samples", "2000", "--starts", "1",
                 "--out", str(tmp_path / "out")]) == 0
    assert capsys.readouterr().err == ""


def test_an_empty_cache_is_announced_before_the_fit(tmp_path, sample, monkeypatch, capsys):
    _terminal(monkeypatch)
    monkeypatch.setenv("BRDF_JAX_CACHE", str(tmp_path / "empty-cache"))
    assert main(["fit", str(sample), "--model", "ggx+lambert", "--samples", "2000", "--starts", "1",
                 "--out", str(tmp_path / "out")]) == 0
    first = capsys.readouterr().err.splitlines()[0]
    assert first.startswith(f"{sample}: fitting 1 model; no compiled programs of this version yet")
    assert "JAX compiles them first, about a minute on 2 cores" in first


def test_a_stored_program_silences_the_note(tmp_path, sample, monkeypatch, capsys):
    from fitting.stored import SUFFIX, folder, source_key, stored_count
    _terminal(monkeypatch)
    monkeypatch.setenv("BRDF_JAX_CACHE", str(tmp_path / "cache"))
    assert stored_count() == 0
    folder().mkdir(parents=True, exist_ok=True)
    (folder() / f"{source_key()}-{'0' * 32}{SUFFIX}").write_bytes(b"x")
    assert stored_count() == 1
    assert main(["fit", str(sample), "--model", "ggx+lambert", "--samples", "2000", "--starts", "1",
                 "--out", str(tmp_path / "out")]) == 0
    first = capsys.readouterr().err.splitlines()[0]
    assert first == f"{sample}: fitting 1 model"


def test_auto_announces_its_screening(tmp_path, sample, monkeypatch, capsys):
    """-q says nothing; auto names the screening (the estimate is then auto's)."""
    _terminal(monkeypatch)
    monkeypatch.setenv("BRDF_JAX_CACHE", str(tmp_path / "empty"))
    from brdf_fit.commands import announce, log
    import logging
    monkeypatch.setattr(log, "level", logging.INFO)
    handler = logging.StreamHandler(io.StringIO())
    log.addHandler(handler)
    try:
        announce("t.binary", 24, screened=True)
    finally:
        log.removeHandler(handler)
    text = handler.stream.getvalue()
    assert text.startswith("t.binary: screening 24 models, then fitting the contenders; no compiled")
    assert "about 3 minutes" in text
