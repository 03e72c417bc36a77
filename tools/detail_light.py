#!/usr/bin/python3
"""The detailed, dense cumulus against the path tracer: the error table of docs/detail.md.

Renders data/scenes/detailed_cumulus.json (liquid water 0.5 g/m^3, droplets of 10 um, erosion
1.5) from its camera, sunlit (the scene's sun), back-lit (the sun 20 degrees above the view
axis, behind the cloud), without the detail, and cumulus27's thin matter with the same detail;
each with the path tracer (the reference; its cache makes a second run quick) and the fast
methods, and prints a markdown table of their error as the accuracy bench measures it: the RMSE
of linear RGB over 4 x 4 pixel block means where either image has alpha > 0.02, relative to the
reference's mean radiance there, with no exposure fit; and the mean ratio and alpha MAE. The
reference's own noise (a second trace of other seeds against it, over sqrt 2) is part of every
error: an error near it says little.

    /usr/bin/python3 tools/detail_light.py [--nephele build/bin/nephele] [--out DIR]
        [--width 160] [--spp 96] [--method ellipsoid ...] [-- extra render options]
"""
import argparse
import datetime
import json
import math
import os
import platform
import subprocess
import sys

import numpy as np
from PIL import Image


def read_pfm(path):
    with open(path, "rb") as f:
        if f.readline().strip() != b"PF":
            raise ValueError(f"{path}: not a colour PFM")
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4").reshape(h, w, 3)
    return data[::-1].astype(np.float64)


def read_alpha(path):
    return np.asarray(Image.open(path).convert("L"), dtype=np.float64) / 255.0


def blocks(a, b=4):
    h, w = a.shape[0] // b, a.shape[1] // b
    a = a[: h * b, : w * b]
    return a.reshape(h, b, w, b, *a.shape[2:]).mean(axis=(1, 3))


def cases(root):
    base = json.load(open(os.path.join(root, "data/scenes/detailed_cumulus.json")))
    out = {"sunlit": json.loads(json.dumps(base))}
    back = json.loads(json.dumps(base))
    cam = back["camera"]
    f = [cam["look_at"][i] - cam["position"][i] for i in range(3)]
    n = math.hypot(f[0], f[1])
    e = math.radians(20)
    back["sun"] = {"direction": [f[0] / n * math.cos(e), f[1] / n * math.cos(e), math.sin(e)]}
    out["back-lit (sun 20° above the view axis)"] = back
    smooth = json.loads(json.dumps(base))
    del smooth["medium"]["detail"]
    out["no detail"] = smooth
    thin = json.load(open(os.path.join(root, "data/scenes/cumulus27.json")))
    thin.setdefault("medium", {})["detail"] = base["medium"]["detail"]
    thin["camera"] = base["camera"]
    out["cumulus27's thin matter, the same detail"] = thin
    return out


def render(nephele, scene_path, method, stem, extra):
    cmd = [nephele, "render", scene_path, "--method", method, "-o", stem + ".png", "--pfm", stem + ".pfm",
           "--alpha", stem + ".alpha.png"] + extra
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"detail_light: {' '.join(cmd)} failed:\n{r.stderr}")
    return read_pfm(stem + ".pfm"), read_alpha(stem + ".alpha.png")


def errors(ref, ref_alpha, img, img_alpha):
    R, RA, A, AA = blocks(ref), blocks(ref_alpha), blocks(img), blocks(img_alpha)
    mask = (RA > 0.02) | (AA > 0.02)
    mean = R[mask].mean()
    d = (A - R)[mask]
    return math.sqrt((d ** 2).mean()) / mean, A[mask].mean() / mean, np.abs(img_alpha - ref_alpha).mean()


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--nephele", default=os.path.join(root, "build/bin/nephele"))
    p.add_argument("--out", default="detail-light-out")
    p.add_argument("--width", type=int, default=160)
    p.add_argument("--spp", type=int, default=96)
    p.add_argument("--method", nargs="+", default=["ellipsoid", "raymarch", "gardner-exact"])
    p.add_argument("extra", nargs="*", help="render options for the fast methods (after --)")
    a = p.parse_args()
    os.makedirs(a.out, exist_ok=True)
    rows = []
    for name, scene in cases(root).items():
        scene["camera"]["width"] = a.width
        scene["camera"]["height"] = a.width * 3 // 4
        slug = "".join(c if c.isalnum() else "_" for c in name.split(" (")[0])
        path = os.path.join(a.out, slug + ".json")
        json.dump(scene, open(path, "w"), indent=1)
        ref, ref_alpha = render(a.nephele, path, "pathtrace", os.path.join(a.out, slug + ".pathtrace"),
                                ["--spp", str(a.spp), "--seed", "7"])
        # The reference's own noise: a second trace of other seeds against it, over sqrt(2).
        other, other_alpha = render(a.nephele, path, "pathtrace", os.path.join(a.out, slug + ".pathtrace2"),
                                    ["--spp", str(a.spp), "--seed", "8"])
        cells = [f"{100 * errors(ref, ref_alpha, other, other_alpha)[0] / math.sqrt(2):.1f}%"]
        for m in a.method:
            img, alpha = render(a.nephele, path, m, os.path.join(a.out, slug + "." + m), a.extra)
            rel, ratio, mae = errors(ref, ref_alpha, img, alpha)
            cells.append(f"{100 * rel:.1f}% / {ratio:.2f} / {mae:.3f}")
        rows.append(f"| {name} | " + " | ".join(cells) + " |")
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    print(f"Measured by `tools/detail_light.py` on {when}, {platform.node() or 'this machine'}, "
          f"{a.width} x {a.width * 3 // 4} px, the path tracer at {a.spp} spp"
          + (f", render options {' '.join(a.extra)}" if a.extra else "") + ": relative RMSE / mean ratio / alpha MAE.\n")
    print("| case | reference noise | " + " | ".join(a.method) + " |")
    print("|---|---|" + "---|" * len(a.method))
    print("\n".join(rows))


if __name__ == "__main__":
    main()
