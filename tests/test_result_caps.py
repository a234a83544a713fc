"""Crafted result files: every string and list has a cap where the file is read
(fitting/result_file.py), the whole file too, so that no command spends more
than seconds or a gigabyte on one; the error names the field and the file."""

import json
import os
import subprocess
import sys
import time

import pytest

from fitting.result import FitResult, ResultFileError
from fitting.result_file import (MAX_ITEMS, MAX_MATERIAL_CHARS, MAX_NAME_CHARS, MAX_PATH_CHARS, MAX_RESULT_BYTES,
                                 MAX_TEXT_CHARS)

from test_result_validation import valid_result

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ENV = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [ROOT, os.environ.get("PYTHONPATH")])))
SECONDS = 30            # a crafted file is refused in about a second (a normal report: ~8 s)
MAX_RSS_KB = 2**20      # 1 GB
# Runs one command and writes its peak resident memory (kB) to argv[1].
MEASURE = ("import resource, subprocess, sys\n"
           "code = subprocess.run(sys.argv[2:]).returncode\n"
           "open(sys.argv[1], 'w').write(str(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss))\n"
           "sys.exit(code)\n")


def _crafted(path, change):
    data = valid_result().to_dict()
    change(data)
    path.write_text(json.dumps(data))
    return path


def _refused(data, source="r.json"):
    with pytest.raises(ResultFileError) as info:
        FitResult.from_dict(data, source=source)
    return str(info.value)


# --- each kind of field has its cap ---------------------------------------------------

def test_caps_are_sensible():
    assert (MAX_NAME_CHARS, MAX_MATERIAL_CHARS, MAX_PATH_CHARS, MAX_TEXT_CHARS, MAX_ITEMS) == (255, 1024, 4096, 1024, 1024)
    assert MAX_RESULT_BYTES == 2**20
    assert len(valid_result().to_json()) < MAX_RESULT_BYTES // 100


@pytest.mark.parametrize("keys, kind, cap", [
    (("provenance", "material"), "a material name", MAX_MATERIAL_CHARS),
    (("provenance", "format"), "a name", MAX_NAME_CHARS),
    (("errors", "exported_model"), "a name", MAX_NAME_CHARS),
    (("toolkit_version",), "a name", MAX_NAME_CHARS),
    (("provenance", "file"), "a file path", MAX_PATH_CHARS),
    (("optimizer", "note"), "a text field", MAX_TEXT_CHARS),
])
def test_a_string_beyond_its_cap_is_refused_naming_the_field(keys, kind, cap):
    data = valid_result().to_dict()
    target = data
    for key in keys[:-1]:
        target = target[key]
    target[keys[-1]] = ("/x" * cap)[:cap]                       # at the cap: fine
    assert FitResult.from_dict(data).to_dict() == data
    target[keys[-1]] += "y"
    assert _refused(data) == (f"r.json: {'.'.join(keys)} is {cap + 1:,} characters long, more than the "
                              f"{cap:,} of {kind} in a fit result")


def test_a_list_or_object_beyond_its_cap_is_refused():
    data = valid_result().to_dict()
    data["optimizer"]["runs"] = data["optimizer"]["runs"] * (MAX_ITEMS + 1)
    assert _refused(data) == (f"r.json: optimizer.runs holds {MAX_ITEMS + 1:,} entries, more than the "
                              f"{MAX_ITEMS:,} of any list or object in a fit result")
    data = valid_result().to_dict()
    data["optimizer"]["options"] = {f"k{i}": i for i in range(MAX_ITEMS + 1)}
    assert _refused(data).startswith("r.json: optimizer.options holds 1,025 entries")


def test_a_long_key_and_a_path_with_an_impossible_name_are_refused():
    data = valid_result().to_dict()
    data["optimizer"]["k" * 256] = 1
    assert _refused(data) == ("r.json: optimizer has a key of 256 characters, more than the 255 of a "
                              "name in a fit result")
    data = valid_result().to_dict()
    data["provenance"]["file"] = "/data/" + "x" * 256 + ".binary"
    assert _refused(data) == ("r.json: provenance.file has a folder or file name of 263 characters, "
                              "more than the 255 any file system allows")


# --- the commands on crafted files: one line, in seconds, under a gigabyte --------------

def _run_measured(argv, tmp_path):
    rss = tmp_path / "rss.txt"
    start = time.monotonic()
    proc = subprocess.run([sys.executable, "-c", MEASURE, str(rss), sys.executable, "-m", "brdf_fit", *argv],
                          env=ENV, capture_output=True, text=True, timeout=3 * SECONDS)
    return proc, time.monotonic() - start, int(rss.read_text())


@pytest.mark.parametrize("field", ["material", "file"])
@pytest.mark.parametrize("command", ["report", "render", "export"])
def test_a_10_mb_string_is_refused_before_it_is_parsed(tmp_path, command, field):
    """Was: report ran for minutes at 5 GB on the name; render, export and report printed a
    400-character line of the path with no reason."""
    path = _crafted(tmp_path / "crafted.json", lambda d: d["provenance"].update({field: "m" * 10**7}))
    out = {"report": tmp_path / "report", "render": tmp_path / "x.png", "export": tmp_path / "x.glb"}[command]
    proc, seconds, rss_kb = _run_measured([command, str(path), "--out", str(out)], tmp_path)
    size = path.stat().st_size
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.splitlines() == [f"brdf-fit {command}: error: {path}: {size:,} bytes is too large "
                                        "for a fit result (at most 1 MiB)"]
    assert seconds < SECONDS and rss_kb < MAX_RSS_KB, (seconds, rss_kb)
    assert not out.exists()


@pytest.mark.parametrize("field, length, message", [
    ("material", 900_000, "provenance.material is 900,000 characters long, more than the 1,024 of a material "
                          "name in a fit result"),
    ("material", 1100, "provenance.material is 1,100 characters long, more than the 1,024 of a material name in a "
                       "fit result"),
    ("file", 5000, "provenance.file is 5,000 characters long, more than the 4,096 of a file path in a fit result"),
    ("file", 4000, "provenance.file has a folder or file name of 3,999 characters, more than the 255 any file "
                   "system allows"),
])
def test_a_field_beyond_its_cap_is_one_line_naming_it(tmp_path, field, length, message):
    path = _crafted(tmp_path / "crafted.json", lambda d: d["provenance"].update({field: "/" + "m" * (length - 1)}))
    proc, seconds, rss_kb = _run_measured(["report", str(path), "--out", str(tmp_path / "report")], tmp_path)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.splitlines() == [f"brdf-fit report: error: {path}: {message}"]
    assert seconds < SECONDS and rss_kb < MAX_RSS_KB, (seconds, rss_kb)
    assert not (tmp_path / "report").exists()


def test_a_result_with_the_longest_names_allowed_makes_a_report(tmp_path):
    """A 255-character material and a 4096-character provenance path (not here): the
    report is written, its file names short enough for any file system."""
    def longest(d):
        d["provenance"].update(material="m" * MAX_NAME_CHARS, file=("/" + "p" * 254) * 16)
    path = _crafted(tmp_path / "longest.json", longest)
    proc, seconds, rss_kb = _run_measured(["report", str(path), "--out", str(tmp_path / "report")], tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert not [line for line in proc.stderr.splitlines() if "error" in line or "arning" in line], proc.stderr
    pages = sorted(p.name for p in (tmp_path / "report").glob("*.html"))
    assert len(pages) == 2 and "index.html" in pages and max(map(len, pages)) <= 100 + len(".html")
    assert seconds < SECONDS and rss_kb < MAX_RSS_KB, (seconds, rss_kb)
