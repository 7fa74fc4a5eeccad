"""Mitsuba 3's side of `make validate`: renders a scene written by `vplgi scene export` in
independent passes (one seed each) and writes their per-pixel mean and sample variance as
OpenEXR, so that its noise can be stated beside vplgi's.

Usage: mitsuba_render.py SCENE_XML OUT_DIR --width W --height H --spp-per-pass S --passes P

Writes OUT_DIR/mean.exr and OUT_DIR/variance.exr (the variance of one pass, divided by P - 1;
the mean's variance is this divided by P) and prints one JSON line: the render seconds (loading
excluded) and the samples per pixel in all.
"""

import argparse
import json
import os
import sys
import time

import mitsuba as mi
import numpy as np


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--width", type=int, required=True)
    ap.add_argument("--height", type=int, required=True)
    ap.add_argument("--spp-per-pass", type=int, required=True)
    ap.add_argument("--passes", type=int, required=True)
    ap.add_argument("--first-seed", type=int, default=0)
    a = ap.parse_args()
    if a.passes < 2:
        sys.exit("--passes must be at least 2 (the variance needs two)")
    # scalar_rgb: RGB rendering on the CPU without LLVM or a GPU, as vplgi renders RGB.
    mi.set_variant("scalar_rgb")
    scene = mi.load_file(a.scene, width=a.width, height=a.height, spp=a.spp_per_pass)
    total = None
    squares = None
    start = time.perf_counter()
    for p in range(a.passes):
        img = np.array(mi.render(scene, seed=a.first_seed + p), dtype=np.float64)[..., :3]
        total = img if total is None else total + img
        squares = img * img if squares is None else squares + img * img
    seconds = time.perf_counter() - start
    mean = total / a.passes
    variance = np.maximum(squares - a.passes * mean * mean, 0.0) / (a.passes - 1)
    os.makedirs(a.out, exist_ok=True)
    for name, img in (("mean", mean), ("variance", variance)):
        tmp = os.path.join(a.out, f".{name}.tmp.exr")
        mi.Bitmap(img.astype(np.float32), mi.Bitmap.PixelFormat.RGB).write(tmp)
        os.replace(tmp, os.path.join(a.out, f"{name}.exr"))
    print(json.dumps({"seconds": seconds, "spp": a.spp_per_pass * a.passes, "passes": a.passes}))


if __name__ == "__main__":
    main()
