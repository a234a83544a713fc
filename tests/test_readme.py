"""The README's front door: the ```python block that opens its Python section
runs as written in a fresh process (headless) and writes what it says."""

import json
import os
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent


def python_section_block():
    """The first ```python block of the README's "## Python" section; it must open the section."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    match = re.search(r"^## Python\n(.*?)(?=^## |\Z)", text, flags=re.M | re.S)
    assert match, "README.md has no '## Python' section"
    section = match.group(1)
    block = re.match(r"\s*```python\n(.*?)^```", section, flags=re.M | re.S)
    assert block, "the Python section does not open with a ```python block"
    return block.group(1)


def test_python_block_is_short_and_complete():
    code = python_section_block()
    lines = [line for line in code.splitlines() if line.strip() and not line.lstrip().startswith("#")]
    assert len(lines) <= 12, f"{len(lines)} lines: the front door should stay a handful"
    for step in ("fit(", "plots.", "export_gltf(", "import"):
        assert step in code, step
    assert "sys.path" not in code and "enable_x64" not in code and "jax_enable" not in code


def test_python_block_runs_in_a_fresh_process(tmp_path):
    code = python_section_block()
    env = {k: v for k, v in os.environ.items() if not k.startswith("JAX_")}
    env["MPLBACKEND"] = "Agg"          # headless, as a script on a server
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "M1 =" in proc.stdout
    m1 = float(proc.stdout.split("M1 =")[1].split()[0])
    assert 0 < m1 < 0.05                       # a real fit of the 2 %-noise table
    png = (tmp_path / "lobes.png").read_bytes()
    assert png.startswith(b"\x89PNG") and len(png) > 10_000
    glb = (tmp_path / "material.glb").read_bytes()
    assert glb[:4] == b"glTF"
    doc = json.loads(glb[20:20 + int.from_bytes(glb[12:16], "little")])
    assert doc["materials"][0]["extras"]["brdf_fit"]["spec"] == "ggx+lambert"
    saved = json.loads((tmp_path / "material.json").read_text())
    assert saved["errors"]["m1"] == pytest.approx(m1, rel=1e-4)
    roughness = saved["parameters"]["roughness"]
    assert roughness == pytest.approx(0.35, rel=0.05)     # the block's table was made with 0.35
