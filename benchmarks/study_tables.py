"""The study's tables (issue 54, docs/study.md) from a library's results.

The study is one library run over the 80 MERL-like tables of ../shared::

    brdf-fit library TABLES --models classic,auto,ggx+lambert,beckmann+lambert+vgroove+f90,\
ashikhmin_shirley_scaled+lambert --out LIB

(the classic models, GGX with a Lambertian and Ngan et al.'s two variants each fitted
fully, ``auto`` screened, the glTF family beside them).  This prints, as markdown, what the
library's analysis page shows (brdf_fit.library.analysis and .study), from the same
functions:

1. every model fitted to every material (the classic models and ggx+lambert): median M1,
   image error and ranking error, and the materials each wins among them;
2. all models, ``auto``'s included (medians over the materials each was refined on):
   the materials each wins;
3. per MERL category: the best classic model by median ranking error and the model
   winning most materials among all;
4. the paired comparisons: GGX against Beckmann, half-vector against mirror-direction lobes.

    python benchmarks/study_tables.py LIB
"""

import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from brdf_fit.library.analysis import analysis_table  # noqa: E402
from brdf_fit.library.study import category_rows, comparison_summary, comparisons  # noqa: E402
from brdf_fit.report.identity import material_groups  # noqa: E402
from brdf_fit.report.pages import collect_results  # noqa: E402
from fitting.auto import CLASSIC_FAMILY  # noqa: E402

# fitted fully to every material in the study (named beside auto), the classic models among them
EVERYWHERE = (*CLASSIC_FAMILY, "ggx+lambert", "beckmann+lambert+vgroove+f90", "ashikhmin_shirley_scaled+lambert")


def _f(x, digits=4):
    return "" if x is None else f"{x:.{digits}g}"


def model_table(groups, title):
    print(f"\n### {title}\n")
    print("| model | materials | wins | median M1 | median image | median ranking | median ratio to the winner |")
    print("|---|---|---|---|---|---|---|")
    for row in analysis_table(groups):
        print(f"| `{row['model']}` | {row['materials']} | {row['wins']} | {_f(row['median_m1'])} | "
              f"{_f(row['median_image'])} | {_f(row['median_ranking'])} | {_f(row['median_ratio'], 3)} |")


def main(argv=None):
    args = sys.argv[1:] if argv is None else argv
    lib = pathlib.Path(args[0])
    found = collect_results([lib / "results"], "study")
    groups = {m: [r for _, r in rows] for m, rows in material_groups(found).items()}
    print(f"{len(groups)} materials")
    everywhere = {m: [r for r in rs if r.spec in EVERYWHERE] for m, rs in groups.items()}
    model_table(everywhere, "Models fitted to every material (the classic models, ggx+lambert, Ngan's variants)")
    classic = {m: [r for r in rs if r.spec in CLASSIC_FAMILY] for m, rs in groups.items()}
    model_table(classic, "The classic set alone (`--models classic`)")
    model_table(groups, "Every model (auto's refined only where screening kept them)")
    print("\n### Per category\n")
    best_classic = {row["category"]: row for row in category_rows(classic)}
    print("| category | materials | best classic (median ranking) | most wins among all models |")
    print("|---|---|---|---|")
    for row in category_rows(groups):
        c = best_classic[row["category"]]
        print(f"| {row['category']} | {row['materials']} | `{c['best_median']}` ({_f(c['median_ranking'])}) | "
              + ", ".join(f"`{m}`" for m in row["most_wins"]) + f" ({row['wins']}) |")
    print("\n### Paired comparisons\n")
    print("| comparison | materials | left better (ranking / M1 / image) | right better | "
          "median right/left M1 | median right/left image |")
    print("|---|---|---|---|---|---|")
    for c in comparisons(groups):
        s = comparison_summary(c)
        counts = [s[k] for k in ("ranking", "m1", "image")]
        print(f"| {c.title} | {s['materials']} | " + " / ".join(str(x["left_better"]) for x in counts) + " | "
              + " / ".join(str(x["right_better"]) for x in counts) + f" | {_f(s['median_ratio_m1'], 3)} | "
              f"{_f(s['median_ratio_image'], 3)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
