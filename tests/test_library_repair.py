"""The same ``brdf-fit library`` command repairs what is missing or damaged in LIB (issue 53, item 5).

A library of two materials is built; then one material's sphere thumbnail, its
viewer data, its page and its .glb (truncated), the viewer's shared script and
materials.glb are deleted or damaged.  The same command writes each of them again,
byte for byte as before, and does not write the other material's files (checked by
their modification times): the check is a stat a file, not a rewrite.
"""

import shutil

import pytest

from brdf_fit.cli import main

FAST = ["--models", "ggx+lambert", "--samples", "400", "--starts", "1", "-q"]


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    from test_library_names import _table
    root = tmp_path_factory.mktemp("repair")
    for seed, name in enumerate(("oak", "slate")):
        _table(root / "in" / f"{name}.npz", name, seed)
    return root / "in"


@pytest.fixture(scope="module")
def library(inputs, tmp_path_factory):
    out = tmp_path_factory.mktemp("lib") / "lib"
    assert main(["library", str(inputs), "--out", str(out), *FAST]) == 0
    return out


def _snapshot(folder):
    return {p.relative_to(folder).as_posix(): (p.read_bytes(), p.stat().st_mtime_ns)
            for p in folder.rglob("*") if p.is_file() and not p.name.startswith(".")}


def _damage(out, oak, case):
    """Delete or truncate one file of the material ``oak`` (its card) or of the library; its name."""
    name = {"thumbnail": oak["measured"], "viewer data": oak["page"].removesuffix(".html") + "-viewer-data.js",
            "viewer script": "materials/viewer.js", "page": oak["page"], "glb": oak["glb"],
            "materials.glb": "materials.glb"}[case]
    if case == "glb":
        (out / name).write_bytes((out / name).read_bytes()[:100])        # a truncated copy
    else:
        (out / name).unlink()
    return name


@pytest.mark.parametrize("case", ["thumbnail", "viewer data", "viewer script", "page", "glb", "materials.glb"])
def test_a_deleted_or_damaged_file_is_written_again_and_nothing_else(inputs, library, tmp_path, case):
    from test_library_names import cards
    out = tmp_path / "lib"
    shutil.copytree(library, out)
    shown = cards(out)
    oak, slate = shown["oak"], shown["slate"]
    before = _snapshot(out)
    name = _damage(out, oak, case)
    assert name in before
    assert main(["library", str(inputs), "--out", str(out), *FAST]) == 0
    after = _snapshot(out)
    assert sorted(after) == sorted(before)
    again = after[name][0].replace(str(out).encode(), str(library).encode())     # a page's command line
    assert again == before[name][0], name
    for key in ("page", "measured", "fitted", "glb"):                    # the other material: not written
        assert after[slate[key]][1] == before[slate[key]][1], key
    assert cards(out)["oak"] == oak


def test_an_untouched_library_is_checked_not_written(inputs, library, tmp_path):
    out = tmp_path / "lib"
    shutil.copytree(library, out)
    before = _snapshot(out)
    assert main(["library", str(inputs), "--out", str(out), *FAST]) == 0
    after = _snapshot(out)
    for name in before:
        if name.startswith(("materials/", "thumbs/", "gltf/")):
            assert after[name][1] == before[name][1], name
