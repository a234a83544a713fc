"""Material names are data: whatever a file's header says, results stay in --out.

A CSV header ``# material: ../../x`` or ``/abs/path``, an NPZ whose
``material`` is ``../../x``, names that are empty, ``..``, ``sub/dir``,
``a\\0b``, hidden (``.x``) or 100 000 characters long: ``fitting.file_names.
safe_stem`` makes each one path component inside the output folder.
"""

import pathlib

import pytest

from fitting.file_names import FALLBACK_STEM, MAX_STEM_BYTES, safe_stem

HOSTILE = {
    "../../x": "_._x",
    "/abs/path": "_abs_path",
    "": FALLBACK_STEM,
    ".": FALLBACK_STEM,
    "..": FALLBACK_STEM,
    "...": FALLBACK_STEM,
    "sub/dir": "sub_dir",
    "sub\\dir": "sub_dir",
    "a\0b": "a_b",
    ".hidden": "hidden",
    " . .x": "x",
    "x.": "x",
    "a..b": "a.b",
    "line\nbreak": "line_break",
    "right\u202eto-left": "right_to-left",      # a bidi override: shows a name backwards
    "bad\udcff\udcfe": "bad__",                  # bytes that were not UTF-8 in a file name
}
SAFE = ["good", "my red paint", "alum-bronze", "rouge (mat) 2", "bl\u00e5", "\u767d\u8272", "a.b", "x_y"]


@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_a_hostile_name_becomes_one_safe_component(name):
    stem = safe_stem(name)
    assert stem == HOSTILE[name]
    _assert_safe(stem)


@pytest.mark.parametrize("name", SAFE)
def test_a_safe_name_is_unchanged(name):
    assert safe_stem(name) == name


@pytest.mark.parametrize("name", ["x" * 100_000, "\u00e9" * 100_000, "a/" * 1000])
def test_a_long_name_is_cut_to_its_byte_bound(name):
    stem = safe_stem(name)
    _assert_safe(stem)
    assert len(stem.encode("utf-8")) <= MAX_STEM_BYTES
    assert len(stem.encode("utf-8")) >= MAX_STEM_BYTES - 3        # cut at a character, not shorter
    assert safe_stem(stem) == stem                                 # idempotent


def test_the_stem_stays_in_its_folder(tmp_path):
    for name in [*HOSTILE, *SAFE]:
        path = (tmp_path / f"{safe_stem(name)}.ggx+lambert.json").resolve()
        assert path.parent == tmp_path.resolve(), name


def _assert_safe(stem):
    assert stem and stem == stem.strip(" .") and not stem.startswith(".")
    assert "/" not in stem and "\\" not in stem and ".." not in stem
    assert all(c.isprintable() for c in stem)
    stem.encode("utf-8")                        # no lone surrogates
    assert pathlib.PurePosixPath(stem).name == stem
