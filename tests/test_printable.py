"""A file name is data: what brdf-fit prints of it cannot colour the terminal, move its cursor,
split a one-line message or show the name backwards (brdf_fit.errors.printable, one_line)."""

import csv
import os
import subprocess
import sys

import pytest

from brdf_fit.errors import one_line, printable

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ESC = "\x1b"
HOSTILE = f"bad{ESC}[31mred\u202etxt.binary"       # a colour sequence and a right-to-left override


@pytest.mark.parametrize("text, shown", [
    (f"a{ESC}[2Jb", "a\\x1b[2Jb"),                # clear screen
    ("a\rb", "a\\x0db"),                           # carriage return: overwrite the line
    ("a\x07b\x7fc\x9bd", "a\\x07b\\x7fc\\x9bd"),    # bell, DEL, C1 CSI
    ("x\u202ey\u2066z", "x\\u202ey\\u2066z"),       # bidi override and isolate
    ("bad\udcff", "bad\\xff"),                      # a byte of a file name that is not UTF-8
    ("blå 白色 (mat) 2.csv", "blå 白色 (mat) 2.csv"),  # printable text unchanged
])
def test_printable_escapes_what_a_terminal_acts_on(text, shown):
    assert printable(text) == shown


def test_one_line_flattens_line_breaks_and_escapes_the_rest():
    assert one_line(f"first line\n  second\tline {ESC}[0m") == "first line second line \\x1b[0m"
    assert all(c.isprintable() for c in one_line(f"{ESC}]0;title\x07 \u202e"))


def _run(*args, cwd):
    return subprocess.run([sys.executable, "-m", "brdf_fit", *args], cwd=cwd, capture_output=True, timeout=300)


def test_a_hostile_file_name_in_an_error_and_in_summary_csv(tmp_path):
    """A truncated table whose name carries an escape sequence and a bidi override: the error is
    one line without either character (each shown escaped), and so is summary.csv's row."""
    bad = tmp_path / HOSTILE
    bad.write_bytes(b"xx")
    fit = _run("fit", str(bad), "--model", "ggx+lambert", "--out", str(tmp_path / "out"), cwd=ROOT)
    assert fit.returncode == 2
    err = fit.stderr.decode("utf-8")
    assert err.count("\n") == 1 and ESC not in err and "\u202e" not in err
    assert "bad\\x1b[31mred\\u202etxt.binary" in err and "too short for the MERL header" in err
    batch = _run("batch", str(bad), "--out", str(tmp_path / "batch"), cwd=ROOT)
    assert batch.returncode == 2
    assert ESC.encode() not in batch.stderr + batch.stdout
    with open(tmp_path / "batch" / "summary.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert [r["file"] for r in rows] == [printable(bad)]
    assert ESC not in rows[0]["file"] and rows[0]["status"].startswith("error")
