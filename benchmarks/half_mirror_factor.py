"""Half vector against mirror direction, with and without the microfacet factor (issue 60, docs/study.md).

The study's direct pair, normalised Blinn-Phong (half vector) against modified Phong (mirror
direction), is two bare lobes; Ngan et al.'s half-vector models carry a microfacet factor the
bare lobe lacks.  ``blinn_phong_mf`` and ``phong_mf`` (brdf/lobes.py) are the same two lobes
times 1 / (4 (wi.h) max(n.wi, n.wo)), so four fits per table separate the lobe's direction
from the factor:

    brdf-fit batch TABLES --models blinn_phong+lambert,phong+lambert,blinn_phong_mf+lambert,\
phong_mf+lambert --jobs 1 --out RESULTS
    python benchmarks/half_mirror_factor.py RESULTS [--ngan]   (a batch --out folder, or LIB/results)

prints, as markdown, each model's medians (M1, image error, ranking error; its largest fitted
rho_s, against the bound 1) and five paired
comparisons by the study's functions (brdf_fit.library.study.compare / comparison_summary):
half against mirror without the factor, with it, the factor on each lobe, and the bare
mirror lobe against the half-vector lobe with the factor.  A ratio is
right's error over left's, per material; its median is printed.  With ``--ngan``, the same
comparisons by Ngan et al.'s L2 (fitting.losses "ngan", which the fits do not minimise), each
fit evaluated on the table its provenance names (fitting.material_errors.m1_errors).
"""

import pathlib
import statistics
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from brdf_fit.library.analysis import analysis_table  # noqa: E402
from brdf_fit.library.study import (DIRECT_PAIR, HALF_VECTOR, MICROFACET_PAIR, MIRROR,  # noqa: E402
                                    compare, comparison_summary)
from brdf_fit.report.identity import material_groups  # noqa: E402
from brdf_fit.report.pages import collect_results  # noqa: E402

MODELS = (*DIRECT_PAIR, *MICROFACET_PAIR)
COMPARISONS = (
    ("half vs mirror, bare lobes", (HALF_VECTOR, DIRECT_PAIR[0]), (MIRROR, DIRECT_PAIR[1])),
    ("half vs mirror, with the factor", (HALF_VECTOR, MICROFACET_PAIR[0]), (MIRROR, MICROFACET_PAIR[1])),
    ("half vector: bare vs with the factor", ("bare", DIRECT_PAIR[0]), ("factor", MICROFACET_PAIR[0])),
    ("mirror: bare vs with the factor", ("bare", DIRECT_PAIR[1]), ("factor", MICROFACET_PAIR[1])),
    ("bare mirror vs half with the factor", (MIRROR, DIRECT_PAIR[1]), (HALF_VECTOR, MICROFACET_PAIR[0])),
)


def _f(x, digits=4):
    return "" if x is None else f"{x:.{digits}g}"


def _median_ratio(rows, name):
    ratios = [r[f"right_{name}"] / r[f"left_{name}"] for r in rows
              if r[f"left_{name}"] and r[f"right_{name}"] is not None]
    return statistics.median(ratios) if ratios else None


def ngan_errors(groups):
    """{(material, model): Ngan's L2} of every fit in ``groups``, on the table it was fitted to."""
    import data_loaders
    from fitting.material_errors import m1_errors
    out = {}
    for material, rs in groups.items():
        measured = data_loaders.load(rs[0].provenance["file"])
        for r, (l2, _) in zip(rs, m1_errors(measured, [(r.spec, r.parameters) for r in rs], loss="ngan")):
            out[material, r.spec] = l2
    return out


def ngan_table(groups, ngan):
    print("\n| comparison by Ngan's L2 (left / right) | materials | left better | right better | "
          "median right/left |")
    print("|---|---|---|---|---|")
    for title, left, right in COMPARISONS:
        both = [(ngan[m, a.spec], ngan[m, b.spec]) for m, a, b in compare(groups, title, title, left, right).pairs]
        if both:
            print(f"| {title} | {len(both)} | {sum(x < y for x, y in both)} | {sum(y < x for x, y in both)} | "
                  f"{_f(statistics.median(y / x for x, y in both), 3)} |")


def main(argv=None):
    args = sys.argv[1:] if argv is None else argv
    found = collect_results([pathlib.Path(args[0])], "study")
    groups = {m: [r for _, r in rows if r.spec in MODELS] for m, rows in material_groups(found).items()}
    groups = {m: rs for m, rs in groups.items() if rs}
    print(f"{len(groups)} materials\n")
    print("| model | materials | wins (of the four) | median M1 | median image | median ranking | largest rho_s |")
    print("|---|---|---|---|---|---|---|")
    for row in analysis_table(groups):
        rho_s = max(max(r.parameters["specular_albedo"]) for rs in groups.values() for r in rs
                    if r.spec == row["model"])
        print(f"| `{row['model']}` | {row['materials']} | {row['wins']} | {_f(row['median_m1'])} | "
              f"{_f(row['median_image'])} | {_f(row['median_ranking'])} | {_f(rho_s, 3)} |")
    print("\n| comparison (left / right) | materials | left better (ranking / M1 / image) | right better | "
          "median right/left ranking | M1 | image |")
    print("|---|---|---|---|---|---|---|")
    for title, left, right in COMPARISONS:
        c = compare(groups, title, title, left, right)
        if not c.pairs:
            continue
        s = comparison_summary(c)
        counts = [s[k] for k in ("ranking", "m1", "image")]
        print(f"| {title} (`{left[1]}` / `{right[1]}`) | {s['materials']} | "
              + " / ".join(str(x["left_better"]) for x in counts) + " | "
              + " / ".join(str(x["right_better"]) for x in counts) + " | "
              + f"{_f(_median_ratio(s['rows'], 'ranking'), 3)} | {_f(s['median_ratio_m1'], 3)} | "
              f"{_f(s['median_ratio_image'], 3)} |")
    if "--ngan" in args[1:]:
        ngan_table(groups, ngan_errors(groups))
    return 0


if __name__ == "__main__":
    sys.exit(main())
