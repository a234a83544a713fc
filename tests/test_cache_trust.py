"""The fitter's caches as untrusted input (fitting/cache_files.py): a stored program or a
compiled executable is used only when the file holds its own key and its digest checks.

A foreign program copied onto a file name (with the same argument shapes), a truncated
file, a flipped bit, a read-only or a full cache folder, two processes filling one folder
at once: every fit gives the numbers of ``BRDF_JAX_CACHE=off``, bit for bit, exits 0, and
writes no native (C++/MLIR) lines on stderr.
"""

import hashlib
import json
import os
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from fitting import cache_files, stored
from fitting.compilation_cache import SUFFIX, SealedCache

from test_cli_corpus import FAST, _samples
from test_disk_faults import fill, mounted_tmpfs

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RUN_LIMIT = 600.0            # seconds for one fit in a fresh process (a loaded 2-core machine)


# --- the seal -----------------------------------------------------------------------------------

def test_a_sealed_file_gives_its_content_for_its_own_key_only():
    data = cache_files.seal("program a", b"\x00content\xff")
    assert cache_files.unseal(data, "program a") == (b"\x00content\xff", "")
    for damaged, key, why in [
            (data, "program b", "another key"),
            (data, "program", "another key"),                  # a prefix of the key is not the key
            (data[:-1], "program a", "truncated"),
            (data + b"x", "program a", "truncated or extended"),
            (data[:-3] + bytes([data[-3] ^ 4]) + data[-2:], "program a", "digest"),
            (b"\x00content\xff", "program a", "not a sealed cache file"),
            (b"", "program a", "not a sealed cache file"),
            (data[:len(cache_files.MAGIC) + 2], "program a", "another key")]:
        content, reason = cache_files.unseal(damaged, key)
        assert content is None and why in reason


def test_the_compilation_cache_misses_on_a_foreign_truncated_or_flipped_entry(tmp_path):
    cache = SealedCache(tmp_path)
    cache.put("jit_f-aaaa", b"executable of f")
    cache.put("jit_g-bbbb", b"executable of g")
    assert cache.get("jit_f-aaaa") == b"executable of f" and cache.get("jit_h-cccc") is None
    f_file, g_file = tmp_path / f"jit_f-aaaa{SUFFIX}", tmp_path / f"jit_g-bbbb{SUFFIX}"
    good = f_file.read_bytes()
    f_file.write_bytes(g_file.read_bytes())                 # another entry copied onto the name
    assert cache.get("jit_f-aaaa") is None
    f_file.write_bytes(good[:-4])
    assert cache.get("jit_f-aaaa") is None
    f_file.write_bytes(good[:-2] + bytes([good[-2] ^ 1]) + good[-1:])
    assert cache.get("jit_f-aaaa") is None
    cache.put("jit_f-aaaa", b"executable of f")             # compiled again: replaced
    assert f_file.read_bytes() == good and cache.get("jit_f-aaaa") == b"executable of f"
    assert sorted(p.name for p in tmp_path.iterdir()) == [f_file.name, g_file.name]   # no temporaries


def test_an_unwritable_folder_is_a_cache_that_keeps_nothing(tmp_path, monkeypatch):
    blocker = tmp_path / "a file"
    blocker.write_text("")
    cache = SealedCache(blocker / "jax")                    # cannot be made
    cache.put("jit_f-aaaa", b"executable")
    assert cache.get("jit_f-aaaa") is None

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(cache_files.os, "replace", full)    # the rename of a full disk's write
    cache = SealedCache(tmp_path / "full")
    cache.put("jit_f-aaaa", b"executable")
    assert cache.get("jit_f-aaaa") is None and list((tmp_path / "full").iterdir()) == []


@pytest.fixture
def programs(tmp_path, monkeypatch):
    monkeypatch.setenv("BRDF_JAX_CACHE", str(tmp_path))
    return tmp_path / "programs"


ARGS = (np.linspace(0.0, 1.0, 7), np.arange(7.0))


def test_a_foreign_stored_program_with_the_same_shapes_is_traced_again(programs):
    """Another program's file (the same argument shapes) copied onto a program's name."""
    sin = stored.stored_jit(lambda x, y: jnp.sin(x) * y, "test trust sin")
    cos = stored.stored_jit(lambda x, y: jnp.cos(x) * y, "test trust cos")
    sin(*ARGS), cos(*ARGS)
    named = {cache_files.sealed_key(p.read_bytes()).splitlines()[1]: p for p in programs.glob("*.jaxexport")}
    sin_file, cos_file = named["test trust sin"], named["test trust cos"]
    sin_file.write_bytes(cos_file.read_bytes())
    calls = []

    def fresh_sin(x, y):                    # a fresh process's function, the same name
        calls.append(1)
        return jnp.sin(x) * y
    again = stored.stored_jit(fresh_sin, "test trust sin")(*ARGS)
    assert calls == [1]
    assert np.array_equal(again, jax.jit(fresh_sin)(*ARGS))
    assert not np.array_equal(again, jnp.cos(ARGS[0]) * ARGS[1])
    calls.clear()
    stored.stored_jit(fresh_sin, "test trust sin")(*ARGS)   # replaced: read, not traced
    assert calls == []


# --- whole fits in fresh processes ---------------------------------------------------------------

def _fit(table, out, cache, *extra):
    """A ggx+lambert fit in a fresh process: (its result's parameters and errors, stderr)."""
    env = dict(os.environ, BRDF_JAX_CACHE=str(cache),
               PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    proc = subprocess.run([sys.executable, "-m", "brdf_fit", "fit", str(table), "--out", str(out), "--json",
                           *FAST, *extra], capture_output=True, text=True, env=env, timeout=RUN_LIMIT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    result = json.loads((out / f"{table.stem}.ggx+lambert.json").read_text())
    return {"parameters": result["parameters"], "errors": result["errors"]}, proc.stderr


def _files(cache):
    return sorted(p for p in cache.rglob("*") if p.is_file() and p.suffix in (".sealed", ".jaxexport"))


def _whole_and_own(files):
    """Every file is a whole sealed file written for the key its name says."""
    for p in files:
        data = p.read_bytes()
        key = cache_files.sealed_key(data)
        assert key is not None and cache_files.unseal(data, key)[0] is not None, p
        named = key if p.suffix == ".sealed" else hashlib.sha256(key.encode()).hexdigest()[:32]
        assert p.name.removesuffix(p.suffix).endswith(named), p


NATIVE_LINES = ("E0000", "W0000", "error: ", "MLIR", "StableHLO", "Traceback", "terminate called")


@pytest.fixture(scope="module")
def uncached(tmp_path_factory):
    """(a sample-list table, the parameters and errors of its fit with BRDF_JAX_CACHE=off)."""
    folder = tmp_path_factory.mktemp("uncached")
    table = _samples(folder / "lab.npz")
    return table, _fit(table, folder / "off", "off")[0]


def test_fits_through_a_damaged_cache_equal_the_uncached_fit_bit_for_bit(tmp_path, uncached):
    table, reference = uncached
    cache = tmp_path / "cache"
    filled, _ = _fit(table, tmp_path / "fill", cache)
    files = _files(cache)
    assert filled == reference
    assert any(p.suffix == ".sealed" for p in files) and any(p.suffix == ".jaxexport" for p in files)
    _whole_and_own(files)
    good = {p: p.read_bytes() for p in files}

    # every file holds another file's content (foreign programs and executables) ...
    contents = [good[p] for p in files]
    for p, content in zip(files, contents[1:] + contents[:1]):
        p.write_bytes(content)
    before = _contents(cache)
    foreign, err = _fit(table, tmp_path / "foreign", cache, "-v")
    assert foreign == reference
    assert "not used (written for another key)" in err, err[-3000:]
    assert not any(s in err for s in NATIVE_LINES), err[-3000:]
    _whole_and_own(_changed(cache, before))                 # replaced by this process's own
    # ... then half of them truncated, the other half with a flipped bit
    for k, p in enumerate(files):
        data = good[p]
        p.write_bytes(data[: len(data) // 2] if k % 2 else data[:-9] + bytes([data[-9] ^ 16]) + data[-8:])
    before = _contents(cache)
    damaged, err = _fit(table, tmp_path / "damaged", cache)
    assert damaged == reference and not any(s in err for s in NATIVE_LINES), err[-3000:]
    _whole_and_own(_changed(cache, before))


def _contents(cache):
    return {p: p.read_bytes() for p in _files(cache)}


def _changed(cache, before):
    """The cache's files a fit wrote: each file it looked up and found foreign or damaged is
    replaced.  Which programs a fit looks up depends on the timing of its compilations
    ahead (one the fit ends before is never asked for), so a file it did not look up
    keeps what it held."""
    changed = [p for p, data in _contents(cache).items() if before.get(p) != data]
    assert changed
    return changed


def test_two_processes_filling_one_cache_at_once_leave_it_whole(tmp_path, uncached):
    table, reference = uncached
    cache = tmp_path / "shared"
    env = dict(os.environ, BRDF_JAX_CACHE=str(cache),
               PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    runs = [subprocess.Popen([sys.executable, "-m", "brdf_fit", "fit", str(table), "--out", str(tmp_path / f"p{k}"),
                              *FAST, "-q"], env=env, stderr=subprocess.PIPE, text=True) for k in range(2)]
    for run in runs:
        _, err = run.communicate(timeout=RUN_LIMIT)
        assert run.returncode == 0, err[-3000:]
    for k in range(2):
        result = json.loads((tmp_path / f"p{k}" / "lab.ggx+lambert.json").read_text())
        assert {"parameters": result["parameters"], "errors": result["errors"]} == reference
    assert _files(cache) and not list(cache.rglob("*.tmp"))
    _whole_and_own(_files(cache))
    again, _ = _fit(table, tmp_path / "again", cache)
    assert again == reference


@pytest.mark.parametrize("state", ["read-only", "full"])
def test_a_read_only_or_full_cache_folder_gives_the_uncached_numbers(tmp_path, state, uncached):
    table, reference = uncached
    with mounted_tmpfs(tmp_path / "disk", size=64 * 1024 * 1024) as disk:
        cache = disk / "cache"
        if state == "read-only":
            _fit(table, tmp_path / "fill", cache)           # a filled cache, then the disk read-only
            subprocess.run(["mount", "-o", "remount,ro", str(disk)], check=True, capture_output=True)
        else:
            cache.mkdir()
            fill(disk)
        before = {p: p.read_bytes() for p in _files(cache)}
        result, err = _fit(table, tmp_path / state, cache)
        assert result == reference and not any(s in err for s in NATIVE_LINES), err[-3000:]
        assert {p: p.read_bytes() for p in _files(cache)} == before
        assert not list(cache.rglob("*.tmp"))
