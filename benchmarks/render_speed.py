"""Milliseconds per 512x512 frame of the preview renderer (headless, EGL).

Run:  .venv/bin/python benchmarks/render_speed.py [--size 512] [--repeat 5]

Prints the GL renderer / version, then the best and median time per frame
(GPU work and read-back; tone mapping to uint8 separately) for:
split-sum IBL (the real-time preview) with and without 4x MSAA, lights only,
and the sampled (Monte-Carlo) IBL used for measured | fitted comparisons.
Setup (context, energy tables, environment prefiltering, shader compiles)
is done before timing and reported on its own.  On Mesa llvmpipe the
numbers are CPU numbers: they scale with the cores and the machine's load.
"""

import argparse
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--model", default="gltf+clearcoat")
    args = parser.parse_args(argv)

    from shaders import image, render
    from shaders.gl import GLUnavailableError, get_context
    try:
        ctx = get_context()
    except GLUnavailableError as exc:
        print(exc)
        return 1
    print(f"GL: {ctx.info['GL_RENDERER']} | OpenGL {ctx.info['GL_VERSION']} | version_code {ctx.version_code}")
    print(f"CPU cores: {os.cpu_count()}, load average: {os.getloadavg()[0]:.1f}")

    params = {"base_color": [0.8, 0.35, 0.12], "metallic": 0.0, "roughness": 0.35,
              "clearcoat": 0.5, "clearcoat_roughness": 0.1}
    from brdf.model import parse_model
    spec = parse_model(args.model)
    base = {p.name: p.default if p.size == 1 else [p.default] * 3 for p in spec.schema()}
    base.update({k: v for k, v in params.items() if k in base})
    material = render.Material(spec, base)

    t0 = time.perf_counter()
    render.render_hdr(material, 16)                                  # context, tables, env, compile
    for ibl in ("sampled", "none"):
        render.render_hdr(material, 16, ibl=ibl)
    print(f"setup (tables, sky prefilter, compiles): {time.perf_counter() - t0:.2f} s")

    cases = [
        ("split-sum IBL + sun, MSAA 4x", dict(ibl="split_sum", msaa=4)),
        ("split-sum IBL + sun, no MSAA", dict(ibl="split_sum", msaa=0)),
        ("lights only (sun), no MSAA", dict(ibl="none", msaa=0)),
        ("sampled IBL, 32 samples x 2 strategies", dict(ibl="sampled", samples=32, msaa=0)),
    ]
    size = args.size
    print(f"\n{args.model} on a sphere, {size}x{size}:")
    for label, kw in cases:
        repeat = args.repeat if kw["ibl"] != "sampled" else max(1, args.repeat // 2)
        times = []
        for _ in range(repeat):
            t = time.perf_counter()
            hdr = render.render_hdr(material, size, **kw)
            times.append(time.perf_counter() - t)
        print(f"  {label:42s} best {min(times) * 1e3:8.1f} ms   median {statistics.median(times) * 1e3:8.1f} ms")
    t = time.perf_counter()
    image.finish(hdr, "aces")
    print(f"  {'tone mapping + sRGB (numpy)':42s} {(time.perf_counter() - t) * 1e3:8.1f} ms")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
