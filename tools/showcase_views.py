#!/usr/bin/python3
"""The showcase's approach beside the path tracer: docs/showcase_views.png and its table.

Places the showcase's camera where data/flights/into_cloud.json has it at the given times (the
flight's keyframes linearly interpolated, as `nephele fly` flies them), renders each view with
the path tracer and the fast methods (`--time t`, so that the layers and the detail are where
the flight sees them), writes the views side by side (a row per time: the path tracer, then
each method) and prints a markdown table of each method's error as tools/detail_light.py
measures it (relative RMSE of 4 x 4 pixel block means where either image has cloud, no
exposure fit; mean ratio; alpha MAE), beside the reference's own noise (the reference is the
mean of two traces of half the samples each; its noise is half their difference), and what
`nephele info` says of each view: how far the cloud is along the line of sight.

    /usr/bin/python3 tools/showcase_views.py [--nephele build/bin/nephele] [--out DIR]
        [--times 3,8,9.5,11] [--width 192] [--spp 128] [--method auto ...] [--png OUT.png]
"""
import argparse
import datetime
import json
import os
import platform
import subprocess
import sys

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from detail_light import errors, render  # noqa: E402


def at(flight, t):
    """The flight's position and look-at at time t (linear between keyframes, held past the ends)."""
    keys = flight["keyframes"]
    if t <= keys[0]["t"]:
        return keys[0]["position"], keys[0]["look_at"]
    for a, b in zip(keys, keys[1:]):
        if t <= b["t"]:
            u = (t - a["t"]) / (b["t"] - a["t"])
            return ([a["position"][i] + u * (b["position"][i] - a["position"][i]) for i in range(3)],
                    [a["look_at"][i] + u * (b["look_at"][i] - a["look_at"][i]) for i in range(3)])
    return keys[-1]["position"], keys[-1]["look_at"]


def srgb(linear):
    """Linear RGB as `nephele render` writes its PNG: clamped to [0, 1], sRGB-encoded."""
    c = np.clip(linear[..., :3], 0, 1)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def line_of_sight(nephele, scene):
    """What `nephele info` says of the camera's line of sight: how far the cloud is."""
    out = subprocess.run([nephele, "info", scene], check=True, capture_output=True, text=True).stdout
    line = [ln for ln in out.splitlines() if ln.startswith("camera: ")][-1]
    return line[len("camera: "):]


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--nephele", default=os.path.join(root, "build/bin/nephele"))
    p.add_argument("--scene", default=os.path.join(root, "data/scenes/showcase.json"))
    p.add_argument("--flight", default=os.path.join(root, "data/flights/into_cloud.json"))
    p.add_argument("--out", default="showcase-views-out")
    p.add_argument("--png", default="", help="the views side by side (default: OUT/showcase_views.png)")
    p.add_argument("--times", default="3,8,9.5,11")
    p.add_argument("--width", type=int, default=192)
    p.add_argument("--spp", type=int, default=128, help="the reference's samples a pixel (two traces of half each)")
    p.add_argument("--method", nargs="+", default=["auto"])
    a = p.parse_args()
    times = [float(t) for t in a.times.split(",")]
    height = a.width * 9 // 16
    os.makedirs(a.out, exist_ok=True)
    base = json.load(open(a.scene))
    flight = json.load(open(a.flight))
    rows, images = [], []
    for t in times:
        scene = json.loads(json.dumps(base))
        pos, look = at(flight, t)
        scene["camera"].update({"position": pos, "look_at": look, "width": a.width, "height": height})
        scene.pop("path", None)  # with --time, a scene's path would place the camera
        stem = os.path.join(a.out, f"t{t:g}")
        json.dump(scene, open(stem + ".json", "w"), indent=1)
        sight = line_of_sight(a.nephele, stem + ".json")
        common = ["--time", f"{t:g}"]
        # The reference: the mean of two traces of spp / 2 each, of other seeds; its own noise is
        # half the difference of the two (the mean's variance is a quarter of the difference's).
        half = ["--spp", str(max(a.spp // 2, 1))]
        one, one_alpha = render(a.nephele, stem + ".json", "pathtrace", stem + ".pathtrace", common + half + ["--seed", "7"])
        two, two_alpha = render(a.nephele, stem + ".json", "pathtrace", stem + ".pathtrace2",
                                common + half + ["--seed", "8"])
        ref, ref_alpha = (one + two) / 2, (one_alpha + two_alpha) / 2
        row = [srgb(ref)]
        cells = [f"{100 * errors(one, one_alpha, two, two_alpha)[0] / 2:.1f}%"]
        for m in a.method:
            img, alpha = render(a.nephele, stem + ".json", m, stem + "." + m, common)
            rel, ratio, mae = errors(ref, ref_alpha, img, alpha)
            cells.append(f"{100 * rel:.1f}% / {ratio:.2f} / {mae:.3f}")
            row.append(stem + "." + m + ".png")
        images.append(row)
        where = ", ".join(f"{v:.0f}" for v in pos)
        rows.append(f"| {t:g} s | ({where}) | {sight} | " + " | ".join(cells) + " |")
    cols = 1 + len(a.method)
    fig, axes = plt.subplots(len(times), cols, figsize=(2.4 * cols, 1.45 * len(times)), squeeze=False)
    for r, row in enumerate(images):
        for c, img in enumerate(row):
            ax = axes[r][c]
            ax.imshow(img if isinstance(img, np.ndarray) else plt.imread(img)[..., :3], interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title("path tracer" if c == 0 else a.method[c - 1], fontsize=8)
            if c == 0:
                ax.set_ylabel(f"t = {times[r]:g} s", fontsize=8)
    fig.tight_layout(pad=0.3)
    png = a.png or os.path.join(a.out, "showcase_views.png")
    fig.savefig(png, dpi=110)
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    print(f"Measured by `tools/showcase_views.py` on {when}, {platform.node() or 'this machine'}, "
          f"{a.width} x {height} px, the path tracer at {a.spp} spp: relative RMSE / mean ratio / alpha MAE "
          f"(wrote {png}).\n")
    print("| flight time | eye (m) | the camera (`nephele info`) | reference noise | " + " | ".join(a.method) + " |")
    print("|---|---|---|---|" + "---|" * len(a.method))
    print("\n".join(rows))
    sys.stdout.flush()


if __name__ == "__main__":
    main()
