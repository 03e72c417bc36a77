#!/usr/bin/python3
"""Colour calibration harness (a tool, not run by CTest): each fast method against the
path-traced reference on small views with medium.noise 0.

    tests/calibrate.py --nephele build/bin/nephele --out /tmp/calib [--spp 1024] [--cache DIR]
                       [--methods ellipsoid,gardner-exact,raymarch] [--views single,cumulus27,...]

For every view it writes OUT/VIEW.json (the scene variant), OUT/VIEW_METHOD.pfm/.png and a
side-by-side strip OUT/VIEW_strip.png (reference first, then the methods in order, each at its
own exposure 1), and prints one line per view and method: the exposure s fitted so that
s * method best matches the reference, and the PSNR after that fit (nephele compare), then a
summary (mean PSNR and mean |log2 s| per method). The reference is cached (--cache), so a second
run costs only the fast methods. Views: the shared scenes at 200x150, the camera inside
cumulus27, cumulus27 and single lit from behind (silver lining), and a scene of our own
with a low western sun (so that nothing is tuned to one sun direction).
"""
import argparse
import copy
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(HERE, "..", "data", "scenes")


def load(name):
    with open(os.path.join(SCENES, name)) as f:
        return json.load(f)


def small(scene, width=200, height=150):
    s = copy.deepcopy(scene)
    s["camera"]["width"], s["camera"]["height"] = width, height
    s.setdefault("medium", {})["noise"] = 0
    return s


def views():
    out = {}
    for name in ("single", "cumulus27", "two_clouds"):
        out[name] = small(load(name + ".json"))
    # The camera inside cumulus27, looking across the cloud towards its far side.
    inside = small(load("cumulus27.json"))
    inside["camera"] = dict(inside["camera"], position=[0, -150, 1600], look_at=[0, 600, 1650], fov_y_deg=70)
    inside["_note"] = "calibrate.py: the camera inside cumulus27"
    out["cumulus27_inside"] = inside
    # Back-lit: the sun behind the cloud, 25 degrees above the horizon (silver lining).
    back = small(load("cumulus27.json"))
    back["sun"] = {"direction": [0.15, 0.88, 0.45]}
    back["_note"] = "calibrate.py: cumulus27 lit from behind"
    out["cumulus27_backlit"] = back
    sback = small(load("single.json"))
    sback["sun"] = {"direction": [-0.2, 0.9, 0.38]}
    sback["_note"] = "calibrate.py: single lit from behind"
    out["single_backlit"] = sback
    # Our own scene: a flat-bottomed cumulus of 7 rotated ellipsoids, low western sun,
    # a greyer sky and a denser medium than the shared scenes.
    own = {
        "cloudscene": 1,
        "_note": "calibrate.py: own scene, low western sun",
        "camera": {"position": [300, -2200, 900], "look_at": [0, 0, 1300], "fov_y_deg": 45, "width": 200, "height": 150},
        "sun": {"direction": [-0.85, 0.15, 0.5], "intensity": 2.5, "color": [1.0, 0.92, 0.8]},
        "sky": {"zenith": [0.15, 0.25, 0.5], "horizon": [0.45, 0.5, 0.6], "ground": [0.15, 0.14, 0.12]},
        "medium": {"extinction": 0.06, "noise": 0},
        "clouds": [{"name": "own", "ellipsoids": [
            {"center": [0, 0, 1300], "radii": [420, 320, 260]},
            {"center": [-380, 80, 1250], "radii": [280, 240, 200], "rotation_deg": [0, 0, 30]},
            {"center": [400, -60, 1280], "radii": [300, 260, 210], "rotation_deg": [10, 0, -20]},
            {"center": [100, 60, 1580], "radii": [260, 220, 220]},
            {"center": [-150, -120, 1520], "radii": [200, 180, 170], "density": 0.7},
            {"center": [250, 150, 1150], "radii": [350, 250, 120]},
            {"center": [-600, 200, 1150], "radii": [220, 200, 110], "density": 1.5},
        ]}],
    }
    out["own_lowsun"] = own
    return out


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("calibrate.py: %s failed (%d): %s" % (" ".join(cmd), r.returncode, r.stderr.strip()))
    return r.stdout


def strip(pngs, out):
    try:
        from PIL import Image
    except ImportError:
        return
    images = [Image.open(p).convert("RGB") for p in pngs]
    w, h = images[0].size
    s = Image.new("RGB", (w * len(images) + 4 * (len(images) - 1), h), (255, 255, 255))
    for i, im in enumerate(images):
        s.paste(im, (i * (w + 4), 0))
    s.save(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--nephele", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--spp", type=int, default=1024)
    ap.add_argument("--cache", default=None, help="path tracer cache (default: nephele's own)")
    ap.add_argument("--methods", default="ellipsoid,gardner-exact,raymarch")
    ap.add_argument("--views", default=None, help="comma-separated subset of the views")
    ap.add_argument("--json", default=None, help="also write the figures here")
    ap.add_argument("--reference", default=None,
                    help="take the references from this --out folder of an earlier run (e.g. to chart another build)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    methods = a.methods.split(",")
    all_views = views()
    chosen = a.views.split(",") if a.views else list(all_views)
    results = {}
    for name in chosen:
        scene = all_views[name]
        path = os.path.join(a.out, name + ".json")
        with open(path, "w") as f:
            json.dump(scene, f, indent=1)
        ref = os.path.join(a.reference or a.out, name + "_pathtrace")
        # Inside a cloud every path scatters many times: a sixteenth of the samples costs as much.
        spp = max(1, a.spp // 16) if name.endswith("_inside") else a.spp
        cmd = [a.nephele, "render", path, "--method", "pathtrace", "--spp", str(spp), "-o", ref + ".png",
               "--pfm", ref + ".pfm", "--alpha", ref + "_alpha.png"]
        if a.cache:
            cmd += ["--cache", a.cache]
        if not a.reference:
            run(cmd)
        pngs = [ref + ".png"]
        for m in methods:
            base = os.path.join(a.out, name + "_" + m)
            run([a.nephele, "render", path, "--method", m, "-o", base + ".png", "--pfm", base + ".pfm"])
            c = json.loads(run([a.nephele, "compare", base + ".pfm", ref + ".pfm"]))
            results.setdefault(name, {})[m] = c
            print("%-18s %-14s exposure %.3f  PSNR %5.2f dB  SSIM %.3f" % (name, m, c["exposure"], c["psnr"] or 99,
                                                                          c["ssim"]), flush=True)
            pngs.append(base + ".png")
        strip(pngs, os.path.join(a.out, name + "_strip.png"))
    import math
    print("summary (mean over %d views):" % len(chosen))
    for m in methods:
        ps = [results[v][m]["psnr"] or 99 for v in chosen]
        es = [abs(math.log2(results[v][m]["exposure"])) for v in chosen]
        print("  %-14s PSNR %5.2f dB   mean |log2 exposure| %.3f" % (m, sum(ps) / len(ps), sum(es) / len(es)))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
