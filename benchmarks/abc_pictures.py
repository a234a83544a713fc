"""The pictures of the largest gaps to ABC (``benchmarks/abc_reference.py --pictures DIR``).

The image error's own scene (fitting/image_error.py), at the viewer's exposure the image error is
taken at and at the fixed exposure 1, side by side, so that no picture rests on the fixed exposure
alone: measured | ABC | each tag's export-first material, each with its image error and M1.
"""

import pathlib

import numpy as np

from abc_reference import abc_at, abc_parameters, evaluate, judged_model

PICTURED = "export-first"       # the glTF family's best export (``--picture-method shipped``: what export ships)


def largest_gaps(rows, tag, count=3, pictured=PICTURED):
    """The ``count`` materials whose ``pictured`` image error is the largest multiple of ABC's in ``tag``."""
    abc, fits = rows[("", "ABC")], rows[(tag, pictured)]
    return sorted(fits, key=lambda m: fits[m][1] / abc[m][1], reverse=True)[:count]


def draw_gap(table, out, tags, rows, folder, pictured=PICTURED):
    """Write FOLDER/abc-gap-MATERIAL.png: measured | ABC | each tag's PICTURED material, at the viewer's
    exposure (the image error's) and at exposure 1 (image_fixed), each with that row's image error and M1."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from data_loaders import load
    from fitting import image_error as ie
    from fitting.result import FitResult
    measured = load(table)
    material = measured.material
    targets = ie.ImageTargets.from_measured(measured)
    abc = abc_at(abc_parameters()[material], targets.report.geo)     # report and fixed share the pairs
    fits = {tag: judged_model(FitResult.load(out / tag / pictured / f"{material}.json"), pictured) for tag in tags}

    def panels(target):
        """(title, the numbers of ``evaluate``, the tone-mapped pixels) of each column."""
        yield "measured", None, target.target
        yield "ABC", rows[("", "ABC")][material], ie.tone_map(ie.pixel_radiance(abc, target), np, target.exposure)
        for tag, (spec, params) in fits.items():
            yield f"{tag} ({pictured})", rows[(tag, pictured)][material], ie.model_image(spec, params, target)

    fig, axes = plt.subplots(2, 2 + len(tags), figsize=(1.7 * (2 + len(tags)), 4.4), squeeze=False)
    for row, (target, which, name) in enumerate(((targets.report, 1, "viewer's exposure"),
                                                 (targets.fixed, 2, "exposure 1"))):
        for ax, (title, numbers, pixels) in zip(axes[row], panels(target)):
            ax.imshow(ie.disc_image(pixels, target), interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(title, fontsize=8)
            if numbers is not None:
                ax.set_xlabel(f"image {numbers[which]:.4f}\nM1 {numbers[0]:.5f}", fontsize=7)
        axes[row][0].set_ylabel(f"{name} (x{float(target.exposure):.3g})", fontsize=7)
    fig.suptitle(f"{material}: the image error's scene; lower numbers are closer to measured", fontsize=8)
    fig.tight_layout()
    path = pathlib.Path(folder) / f"{'abc' if pictured == PICTURED else pictured}-gap-{material}.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(path.name + ".partial")
    fig.savefig(partial, format="png", dpi=100)
    plt.close(fig)
    partial.replace(path)
    numbers = [("ABC", rows[("", "ABC")][material])] + [(tag, rows[(tag, pictured)][material]) for tag in tags]
    print(f"{material}: " + "; ".join(f"{name} M1 {v[0]:.5f} image {v[1]:.4f} fixed {v[2]:.4f}" for name, v in numbers)
          + "; image / ABC's " + " -> ".join(f"{v[1] / numbers[0][1][1]:.3f}" for _, v in numbers[1:])
          + f"; {path} ({path.stat().st_size // 1024} KB)")


def write_pictures(chosen, tables, out, tags, folder, pictured=PICTURED):
    """Draw ``chosen`` tables (None: the three of ``tables`` with the largest gaps in ``tags[0]``)."""
    rows = evaluate(tables, out, tags, methods=(pictured,))
    if chosen is None:
        chosen = [t for m in largest_gaps(rows, tags[0], pictured=pictured) for t in tables if t.stem == m]
    for table in chosen:
        draw_gap(table, out, tags, rows, folder, pictured)
