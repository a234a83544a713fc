"""Image fidelity of `--model auto`: the log loss ranked by M1 (the first round's
auto) against the hybrid loss ranked by M1 + 0.3 x image error (the default).

    python benchmarks/image_fidelity.py TABLE_OR_FOLDER... --out DIR [--image-weight 0.3]

Runs `brdf-fit batch --model auto` twice into DIR/log and DIR/hybrid-<w>
(resumable: finished results are kept), then prints per material the
winner of each and its M1 and image error, the medians, and the changes.
With --export it also times `brdf-fit export TABLE` (export-first) in a fresh
process on the first table and compares the written material's image error
with the best engine model's.  Without arguments it uses the ten MERL-like
tables made from ../shared's Neural-BRDF networks (written to DIR/tables).
"""

import argparse
import json
import pathlib
import statistics
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
METALS = ("chrome", "alum-bronze", "gold-metallic-paint", "black-oxidized-steel")


def dev_tables(folder):
    """The ten dev tables from ../shared (not part of the project), written once."""
    npz = SHARED / "measured" / "nbrdf-merl" / "merl_nbrdf_dev.npz"
    tool = SHARED / "tools" / "merl_from_nbrdf.py"
    import numpy as np
    folder.mkdir(parents=True, exist_ok=True)
    for material in np.load(npz)["materials"]:
        out = folder / f"{material}.binary"
        if not out.exists():
            subprocess.run([sys.executable, str(tool), str(npz), str(material), str(out)], check=True,
                           capture_output=True)
    return [str(folder)]


def run(inputs, out, loss, weight):
    cmd = [sys.executable, "-m", "brdf_fit.cli", "batch", *inputs, "--model", "auto", "--loss", loss,
           "--image-weight", str(weight), "--out", str(out), "-q"]
    t = time.perf_counter()
    subprocess.run(cmd, check=False)
    return time.perf_counter() - t


def winners(folder, key):
    from fitting.result import FitResult
    best = {}
    for path in sorted(pathlib.Path(folder).glob("*.json")):
        r = FitResult.load(path)
        if r.material not in best or key(r.errors) < key(best[r.material].errors):
            best[r.material] = r
    return best


def main():
    from fitting.ranking import ranking_error
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("inputs", nargs="*")
    ap.add_argument("--out", default="image-fidelity")
    ap.add_argument("--image-weight", type=float, default=0.3)
    ap.add_argument("--export", action="store_true", help="also time export-first on the first table")
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    inputs = args.inputs or dev_tables(out / "tables")
    hybrid_dir = out / f"hybrid-{args.image_weight:g}"
    for folder, loss in ((out / "log", "log"), (hybrid_dir, "hybrid")):
        seconds = run(inputs, folder, loss, args.image_weight)
        print(f"batch --loss {loss}: {seconds:.0f} s (0 s when resumed)", file=sys.stderr)
    old = winners(out / "log", lambda e: e["m1"])
    new = winners(hybrid_dir, ranking_error)
    print(f"{'material':<26}{'first-round auto (log, by M1)':>44}   {'default (hybrid, ranked)':>44}"
          f"  {'image':>7} {'M1':>7}")
    rows = []
    for m in sorted(old):
        a, b = old[m], new.get(m)
        if b is None:
            continue
        di = b.errors["image"] / a.errors["image"] - 1
        dm = b.errors["m1"] / a.errors["m1"] - 1
        rows.append((m, a, b, di, dm))
        print(f"{m:<26}{a.spec:>28} {a.errors['m1']:.5f} {a.errors['image']:.4f}   "
              f"{b.spec:>28} {b.errors['m1']:.5f} {b.errors['image']:.4f}  {di:+7.1%} {dm:+7.1%}")
    med = lambda rs, k: statistics.median(r.errors[k] for r in rs)   # noqa: E731
    olds, news = [r[1] for r in rows], [r[2] for r in rows]
    print(f"median image error {med(olds, 'image'):.4f} -> {med(news, 'image'):.4f} "
          f"({med(news, 'image') / med(olds, 'image') - 1:+.1%}); "
          f"median M1 {med(olds, 'm1'):.5f} -> {med(news, 'm1'):.5f} ({med(news, 'm1') / med(olds, 'm1') - 1:+.1%})")
    print("metals: " + ", ".join(f"{m} {di:+.1%}" for m, _, _, di, _ in rows if m in METALS))
    if args.export:
        table = sorted(pathlib.Path(inputs[0]).glob("*.binary"))[0] if pathlib.Path(inputs[0]).is_dir() \
            else pathlib.Path(inputs[0])
        glb = out / f"{table.stem}.glb"
        t = time.perf_counter()
        doc = subprocess.run([sys.executable, "-m", "brdf_fit.cli", "export", str(table), "--out", str(glb),
                              "--json", "-q"], check=True, capture_output=True, text=True).stdout
        seconds = time.perf_counter() - t
        written = json.loads(doc)["written"]["honesty"]
        engine = new[table.stem]
        print(f"export-first {table.stem}: {seconds:.1f} s in a fresh process; written image error "
              f"{written['image_exported_gltf']:.4f} vs the best engine model's {engine.errors['image']:.4f} "
              f"({written['image_exported_gltf'] / engine.errors['image'] - 1:+.1%})")


if __name__ == "__main__":
    main()
