"""What export and the library ship, per MERL category (``benchmarks/abc_reference.py --shipped``).

The shipped glTF material and the library's converted material before it, over ABC's image
error, plain sRGB RMSE at the viewer's exposure and M1, material by material, per category and
overall (the rows of abc_reference's ``evaluate``).
"""

import statistics

from brdf_fit.library.categories import category     # MERL's categories by name (Ngan et al. 2005)


def show_shipped(rows, tag):
    """What a user takes away, material by material: the shipped glTF (export and library) and the
    library's converted material before it, each over ABC's image error, sRGB RMSE and M1; then
    per category and overall (medians, how many above ABC, how many the new rule made worse)."""
    abc, new, old = rows[("", "ABC")], rows.get((tag, "shipped"), {}), rows.get((tag, "converted"), {})
    common = sorted(set(new) & set(old), key=lambda m: (category(m), m))
    ratio = {(k, m): tuple(v[i] / abc[m][i] for i in (1, 5, 0)) for k, d in (("new", new), ("old", old))
             for m, v in d.items()}
    print("| category | material | shipped image / sRGB / M1 over ABC | converted (before) image / sRGB / M1 |")
    print("|---|---|---|---|")
    for m in common:
        print(f"| {category(m)} | {m} | " + " | ".join(" / ".join(f"{x:.2f}" for x in ratio[(k, m)])
                                                     for k in ("new", "old")) + " |")
    print("\n| category | n | shipped: median image / M1 over ABC, above ABC (image) | converted: the same |")
    print("|---|---|---|---|")
    def cells(k, ms):
        img = [ratio[(k, m)][0] for m in ms]
        return (f"{statistics.median(img):.3f} / {statistics.median(ratio[(k, m)][2] for m in ms):.3f}, "
                f"{sum(x > 1.0 for x in img)}")
    for c in sorted({category(m) for m in common}) + ["all"]:
        ms = [m for m in common if c in ("all", category(m))]
        print(f"| {c} | {len(ms)} | {cells('new', ms)} | {cells('old', ms)} |")
    worse = [m for m in common if new[m][1] > old[m][1] * 1.0001]
    print(f"\nshipped image error worse than the converted material's on {len(worse)} of {len(common)}: "
          + ", ".join(f"{m} {new[m][1] / old[m][1]:.3f}x" for m in worse))
