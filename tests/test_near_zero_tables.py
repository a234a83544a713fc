"""Tables with (almost) nothing to fit warn as an all-zero one does: all 1e-30, or zero
but for one cell (data_loaders.measured: NEGLIGIBLE_BRDF, MIN_SIGNAL_FRACTION)."""

import dataclasses
import warnings

import numpy as np
import pytest

from brdf_fit.cli import main
from data_loaders import write_samples
from data_loaders.measured import MIN_SIGNAL_FRACTION, NEGLIGIBLE_BRDF, plausibility_problems
from fitting.synthetic import synthetic_measured

from test_cli_corpus import FAST, TRUTH

NOTHING = "nothing to fit, the fitted parameters will sit at their bounds"


def _table(path, values):
    """A sample file on the corpus's grid (2,612 valid samples) with ``values(n)`` as its RGB."""
    m = synthetic_measured("ggx+lambert", TRUTH, grid=(12, 12, 24, 1))
    keep = np.flatnonzero(m.valid)
    write_samples(path, m.wi[keep], m.wo[keep], values(len(keep)), weights=m.weights[keep],
                  material=path.stem, isotropic=True)
    return path


def _one_cell(n):
    v = np.zeros((n, 3))
    v[5] = 0.3
    return v


CASES = {
    "tiny": (lambda n: np.full((n, 3), 1e-30), f"all values are at most 1e-06 1/sr (peak 1e-30): {NOTHING}"),
    "one-cell": (_one_cell, f"only 1 of 2,612 valid samples are above 1e-06 1/sr: {NOTHING}"),
    "zero": (lambda n: np.zeros((n, 3)), f"all values are zero: {NOTHING}"),
}


@pytest.mark.parametrize("command", ["info", "fit"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_a_near_zero_table_warns_naming_its_file(tmp_path, capsys, case, command):
    make, message = CASES[case]
    path = _table(tmp_path / f"{case}.npz", make)
    argv = ["info", str(path)] if command == "info" else ["fit", "-q", str(path), "--out", str(tmp_path), *FAST]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert err.splitlines() == [f"brdf-fit {command}: warning: {path}: {message}"], err


def test_the_threshold_flags_faint_tables_and_spares_dark_and_sharp_materials():
    """A black material (albedo 0.005, F0 0.02) and a GGX mirror below the roughness floor
    (no diffuse) are far from the threshold; the mirror scaled by 1e-12 is not."""
    assert (NEGLIGIBLE_BRDF, MIN_SIGNAL_FRACTION) == (1e-6, 0.01)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dark = synthetic_measured("ggx+lambert", {"albedo": [0.005] * 3, "roughness": 0.3, "f0": [0.02] * 3},
                                  grid=(12, 12, 24, 1))
        mirror = synthetic_measured("ggx", {"roughness": 0.02, "f0": [0.04] * 3}, grid=(12, 12, 24, 1))
    assert plausibility_problems(dark) == [] and plausibility_problems(mirror) == []
    faint = dataclasses.replace(mirror, values=mirror.values * 1e-12)      # a mirror in wrong units
    assert plausibility_problems(faint) == [f"all values are at most 1e-06 1/sr (peak 1.9e-07): {NOTHING}"]
