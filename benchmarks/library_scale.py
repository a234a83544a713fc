"""A library at scale (issue 42): N MERL-size tables through ``brdf-fit library`` on this machine.

The tables (MERL .binary, 90 x 90 x 180 x 3 doubles, 35 MB each) are written into a
temporary folder, never into the repository, from two sources in ../shared:

- the ten measured dev tables, regenerated from their NBRDF networks
  (``tools/merl_from_nbrdf.py``);
- the published ABC fits of the same ten materials (Loew et al. 2012,
  ``measured/abc-low2012/abc_dev.csv``), evaluated on the MERL grid by
  benchmarks/abc_reference.py's ``abc_brdf``;
- variations of both, each seeded by its index: an ABC material with its A scaled
  (x 0.3-3), B scaled (x 0.5-2, a wider or narrower lobe), C moved (+-0.3), its kd
  tinted by a random colour and its ior moved (1.3-2.5); a dev table with its
  RGB scaled by a random tint (0.4-1.6 per channel).

Recipes are interleaved (dev, ABC, dev variation, ABC variation, ...) so any first
N is a mix; the hundred are the 10 dev tables, the 10 ABC tables and 80 variations.

Measured, each run a fresh ``brdf-fit`` process as a user runs it:

1. the caches filled (a first ``library`` run over a few tables fills the JAX
   compilation cache), the fits of N tables: ``brdf-fit library TABLES --jobs 2``
   (``auto``), its wall time, and the projection to 100 tables;
2. the library pages (everything after the fits) on their own: the pages' files
   removed, ``brdf_fit.library.write_library(LIB/results, LIB, jobs=2)`` in a fresh
   process (its wall time: start, imports, every page); the same for a library of one
   material gives the fixed cost, so the projection to 100 tables is the fixed cost
   plus 100 x the cost per material (not the N-table time scaled);
   then the same command again on the same folder with the pages' files removed: the
   batch's resume (it reads and hashes each table; ``auto`` takes each table's screening
   from its record, brdf_fit/batch/screening_record.py) and the pages, as a user
   re-running the command sees them;
3. peak RSS: the largest of the processes' maximum resident sets (ru_maxrss of the
   waited-for children: the command and its worker processes);
4. the same library through a local Dask cluster (a scheduler and two one-thread
   workers on 127.0.0.1, benchmarks/library_cost.py's ``Cluster``): its pages equal
   the local run's;
5. index.html: its size, and the time headless Chromium takes to draw it (load
   to every picture decoded), when Chromium is here.

    python benchmarks/library_scale.py [--tables N] [--no-dask] [--dev-tables DIR]

(``--dev-tables``: a folder holding the ten dev tables already made by the tool, copied
instead of made again.  ``--measured DIR``: the MERL tables of DIR instead -- the 80 of
../shared made by ``tools/merl_from_nbrdf.py``, the library the issue's target is about --
read where they are.)
"""

import argparse
import os
import pathlib
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parent.parent
SHARED = ROOT.parent / "shared"
TOOL = SHARED / "tools" / "merl_from_nbrdf.py"
WEIGHTS = SHARED / "measured" / "nbrdf-merl" / "merl_nbrdf_dev.npz"
PYTHON = sys.executable
LIBRARY = 100
FIT_TARGET, PAGES_TARGET = 15 * 60, 60       # seconds (issue 42)
INDEX_MB, DRAW_SECONDS = 5.0, 1.0
sys.path[:0] = [str(ROOT / "benchmarks"), str(ROOT / "tests")]


def recipes(count=LIBRARY):
    """[(name, kind, source material, seed)]: dev, abc, dev variation, abc variation, ..."""
    from abc_reference import ABC_DEV_CSV, abc_parameters
    names = sorted(abc_parameters(ABC_DEV_CSV))         # the ten dev materials (their networks are in WEIGHTS)
    out = [(n, "dev", n, 0) for n in names] + [(f"abc-{n}", "abc", n, 0) for n in names]
    for k in range(LIBRARY - len(out)):
        kind = ("dev", "abc")[k % 2]
        source = names[(k // 2) % len(names)]
        out.append((f"{kind}-{source}-v{k}", kind + "-var", source, k + 1))
    dev, abc, var = out[:10], out[10:20], out[20:]
    mixed = [x for pair in zip(dev, abc, var[0::2], var[1::2]) for x in pair] + var[20:]
    return mixed[:count]


def _geometry(folder):
    """(wi, wo, valid) of every MERL cell, from one dev table."""
    from data_loaders import load
    m = load(_dev_table(folder, "blue-acrylic"))
    return m.wi, m.wo, np.asarray(m.valid)


def _dev_table(folder, name):
    path = folder / "dev" / f"{name}.binary"
    if not path.is_file():
        path.parent.mkdir(exist_ok=True)
        subprocess.run([PYTHON, str(TOOL), str(WEIGHTS), name, str(path)], check=True, capture_output=True)
    return path


def _abc_table(p, wi, wo):
    from abc_reference import abc_brdf
    h = wi + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    return abc_brdf(p, wi[:, 2], wo[:, 2], h[:, 2], np.sum(wo * h, axis=1))


def make_tables(folder, count):
    """Write ``count`` tables (``recipes``) into ``folder``; their paths."""
    from abc_reference import abc_parameters
    from data_loaders.merl import MERL_SHAPE, read_merl, write_merl
    abc = abc_parameters()
    wi, wo, valid = _geometry(folder)
    paths = []
    for name, kind, source, seed in recipes(count):
        rng = np.random.default_rng(seed)
        path = folder / f"{name}.binary"
        if kind == "dev":
            shutil.copyfile(_dev_table(folder, source), path)
        elif kind == "dev-var":
            table = read_merl(_dev_table(folder, source)).table
            write_merl(path, table.rgb * rng.uniform(0.4, 1.6, 3), table.valid)
        else:
            p = dict(abc[source])
            if kind == "abc-var":
                p = {"kd": p["kd"] * rng.uniform(0.2, 3.0, 3), "a": p["a"] * rng.uniform(0.3, 3.0),
                     "b": p["b"] * rng.uniform(0.5, 2.0), "c": max(0.3, p["c"] + rng.uniform(-0.3, 0.3)),
                     "ior": rng.uniform(1.3, 2.5) if p["ior"] < 10 else p["ior"]}
            rgb = _abc_table(p, wi, wo).reshape(MERL_SHAPE + (3,))
            write_merl(path, np.where(valid.reshape(MERL_SHAPE)[..., None], rgb, 0.0), valid.reshape(MERL_SHAPE))
        paths.append(path)
    return paths


def library(label, tables, out, env, *extra):
    """Run ``brdf-fit library`` (a fresh process); its wall seconds."""
    argv = [PYTHON, "-m", "brdf_fit", "library", *map(str, tables), "--out", str(out), "-q", *extra]
    t = time.perf_counter()
    res = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if res.returncode != 0:
        raise RuntimeError(f"{label}: exit {res.returncode}: {res.stderr.strip()[-2000:]}")
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    print(f"{label:44s} wall {wall:7.1f} s  ({wall / len(tables):5.2f} s/table; peak RSS so far {peak:6.0f} MB)")
    return wall


PAGES_ONLY = ("import sys; from brdf_fit.library import write_library; "
              "write_library(sys.argv[1:-1], sys.argv[-1], jobs=2, log=lambda s: None, "
              "command_line='brdf-fit library (the pages only)')")


def pages_only(label, results, out, env):
    """``write_library(results, out, jobs=2)`` in a fresh process; its wall seconds."""
    argv = [PYTHON, "-c", PAGES_ONLY, *map(str, results), str(out)]
    t = time.perf_counter()
    res = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if res.returncode != 0:
        raise RuntimeError(f"{label}: exit {res.returncode}: {res.stderr.strip()[-2000:]}")
    print(f"{label:44s} wall {wall:7.1f} s")
    return wall


def remove_pages(lib):
    """Remove everything of a library but its results."""
    for name in ("materials", "thumbs", "gltf", "analysis"):
        shutil.rmtree(lib / name, ignore_errors=True)
    for name in ("index.html", "analysis.html", "materials.glb", ".library-state.json"):
        (lib / name).unlink(missing_ok=True)


def _pages(folder):
    """Every page of a library, its folder's path and the command line taken out."""
    out = {}
    for page in [folder / "index.html", folder / "analysis.html", *(folder / "materials").glob("*.html")]:
        text = page.read_text(encoding="utf-8").replace(str(folder), "LIB")
        out[page.relative_to(folder).as_posix()] = re.sub(r"brdf-fit library [^<]*", "COMMAND", text)
    return out


def draw_seconds(index):
    """Seconds headless Chromium takes from opening ``index`` to every picture decoded, or None."""
    from headless_chromium import HeadlessChromium, find_chromium
    if find_chromium() is None:
        return None
    with tempfile.TemporaryDirectory() as tmp, HeadlessChromium(tmp, width=1200, height=900) as browser:
        t = time.perf_counter()
        browser.open(index.as_uri())
        browser.wait_for("document.readyState === 'complete' && "
                         "Array.from(document.images).every(i => i.complete && i.naturalWidth > 0)")
        return time.perf_counter() - t


def reference_pass(table, when):
    """Print the naive reference pass (docs/performance.md): library_cost.py's, on ``table``."""
    from library_cost import naive_reference
    print(f"({when})")
    naive_reference(table, 1, cores=1)


def main():
    from brdf_fit.library.build import PAGES_PER_WORKER
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tables", type=int, default=LIBRARY, help=f"number of tables (default {LIBRARY})")
    parser.add_argument("--no-dask", action="store_true", help="skip the Dask run")
    parser.add_argument("--dev-tables", type=pathlib.Path, help="a folder with the ten dev tables already made")
    parser.add_argument("--measured", type=pathlib.Path,
                        help="fit the MERL .binary tables of this folder (the first --tables of them, by name) "
                             "instead of making tables; the projection to 100 scales their time")
    parser.add_argument("--keep", type=pathlib.Path,
                        help="copy the library made (results, pages, materials.glb) to this new folder, "
                             "for the engine judges (benchmarks/engine_three.py --glb-dir DIR/gltf)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="library-scale-") as tmp:
        tmp = pathlib.Path(tmp)
        (tmp / "tables").mkdir()
        if args.dev_tables:
            shutil.copytree(args.dev_tables, tmp / "tables" / "dev")
        t = time.perf_counter()
        tables = (sorted(args.measured.glob("*.binary"))[:args.tables] if args.measured
                  else make_tables(tmp / "tables", args.tables))
        print(f"{len(tables)} tables ready in {time.perf_counter() - t:.0f} s; {os.cpu_count()} cores, "
              f"load average {os.getloadavg()[0]:.1f}")
        env = dict(os.environ, BRDF_JAX_CACHE=str(tmp / "jax-cache"))
        library("filling the caches (4 tables)", tables[:4], tmp / "warm", env, "--jobs", "2")
        reference_pass(tables[0], "before the fits")
        fits_and_pages = library(f"library of {len(tables)}, --jobs 2", tables, tmp / "lib", env, "--jobs", "2")
        reference_pass(tables[0], "after them")
        lib = tmp / "lib"
        reference = _pages(lib)
        remove_pages(lib)
        pages = pages_only(f"the pages alone ({len(tables)} materials), jobs=2", [lib / "results"], lib, env)
        same = _pages(lib) == reference
        one = sorted((lib / "results").glob(f"{tables[0].stem}.*.json"))
        fixed = pages_only("the pages alone (1 material): the fixed cost", one, tmp / "one", env)
        remove_pages(lib)
        again = library("the command again (fits resumed, pages)", tables, lib, env, "--jobs", "2")
        assert _pages(lib) == reference, "the pages written again differ"
        fits = fits_and_pages - pages
        scale = LIBRARY / len(tables)
        each = max(pages - fixed, 0.0) / max(len(tables) - 1, 1)
        print(f"fits: {fits:.0f} s for {len(tables)} -> {LIBRARY} tables: {fits * scale / 60:.1f} min "
              f"(target {FIT_TARGET / 60:.0f}; the pages' time taken out)")
        print(f"pages: {pages:.1f} s for {len(tables)} (equal to the first run's: {same}), fixed {fixed:.1f} s, "
              f"{each:.2f} s per material -> {LIBRARY}: {fixed + each * (LIBRARY - 1):.0f} s (target "
              f"{PAGES_TARGET}; workers start from {PAGES_PER_WORKER} pages per worker); the resume and "
              f"pages of the command again: {again:.1f} s -> {LIBRARY}: {again * scale:.0f} s")
        size = (lib / "index.html").stat().st_size / 1e6
        thumbs = sum(p.stat().st_size for p in (lib / "thumbs").glob("*.png")) / 1e6
        draw = draw_seconds(lib / "index.html")
        print(f"index.html {size:.3f} MB (+ thumbnails {thumbs:.2f} MB) for {len(tables)} materials "
              f"-> {LIBRARY}: {(size + thumbs) * scale:.2f} MB (target {INDEX_MB:g}); drawn in Chromium in "
              + (f"{draw:.2f} s" if draw is not None else "(no Chromium here)"))
        if not args.no_dask:
            from library_cost import Cluster
            with Cluster(tmp, env) as cluster:
                library(f"library of {len(tables)}, Dask (2 workers)", tables, tmp / "dask", env,
                        "--scheduler", cluster.address, "--jobs", "2")
            same = _pages(tmp / "dask") == reference
            print(f"Dask's pages equal the local run's: {same}")
        peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        print(f"peak RSS of any process: {peak:.0f} MB")
        if args.keep:
            shutil.copytree(lib, args.keep)
            print(f"the library kept in {args.keep}")


if __name__ == "__main__":
    main()
