#!/usr/bin/python3
"""Charts of `nephele bench --accuracy`.
accuracy_chart.png: per noise setting, summed ms per frame (log) against the mean relative error
of every method and setting, one colour per method, the Pareto front joined.
accuracy_distance.png: each method's default against the distance to the cloud.
Usage: /usr/bin/python3 bench/plot_accuracy.py ACCURACY.csv OUT_DIR "WHEN"
(Debian's python3-matplotlib: call /usr/bin/python3, not the python3 first on PATH.)"""
import csv
import os
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLOURS = {"ellipsoid": "tab:blue", "raymarch": "tab:orange", "gardner-exact": "tab:green",
           "pathtrace": "tab:red", "layered": "tab:purple"}


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    rows = list(csv.DictReader(open(sys.argv[1])))
    out_dir, when = sys.argv[2], sys.argv[3]

    # Aggregate like the bench: per noise, method, setting, over the cases every setting has.
    agg = defaultdict(lambda: {"ms": 0.0, "err": 0.0, "n": 0, "pareto": False})
    for r in rows:
        a = agg[(r["noise"], r["method"], r["setting"])]
        a["ms"] += float(r["ms"])
        a["err"] += float(r["rel_rmse"])
        a["n"] += 1
        a["pareto"] = r["pareto"] == "1"
    full = defaultdict(int)
    for (noise, _, _), a in agg.items():
        full[noise] = max(full[noise], a["n"])

    fig, axes = plt.subplots(1, 2, figsize=(12, 5), dpi=100)
    for ax, noise, title in [(axes[0], "0", "medium.noise 0 (exact field)"), (axes[1], "scene", "scenes' noise")]:
        pts = [(k[1], k[2], a["ms"], 100 * a["err"] / a["n"], a["pareto"]) for k, a in agg.items()
               if k[0] == noise and a["n"] == full[noise]]
        for method in COLOURS:
            mp = [p for p in pts if p[0] == method]
            if not mp:
                continue
            ax.scatter([p[2] for p in mp], [p[3] for p in mp], c=COLOURS[method], label=method, s=28, zorder=3)
            for p in mp:
                ax.annotate(p[1], (p[2], p[3]), fontsize=6, xytext=(3, 2), textcoords="offset points")
        front = sorted([p for p in pts if p[4]], key=lambda p: p[2])
        if front:
            ax.plot([p[2] for p in front], [p[3] for p in front], "k--", lw=1, label="Pareto front", zorder=2)
        ax.set_xscale("log")
        ax.set_xlabel("ms per frame, summed over the cases (log)")
        ax.set_ylabel("mean relative RMSE vs path-traced reference (%)")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Nephele: speed against accuracy — " + when, fontsize=11)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "accuracy_chart.png"))

    # Distance series: the defaults, with the scenes' noise.
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), dpi=100)
    series = defaultdict(list)
    for r in rows:
        if r["noise"] != "scene" or not r["distance_m"]:
            continue
        if r["method"] in ("ellipsoid", "raymarch") and r["setting"] != "default":
            continue
        series[r["method"]].append((float(r["distance_m"]), 100 * float(r["rel_rmse"]), float(r["ms"])))
    for method, pts in series.items():
        pts.sort()
        # "inside" (0 m) is drawn at 100 m on the log axis
        xs = [max(p[0], 100.0) for p in pts]
        axes[0].plot(xs, [p[1] for p in pts], "o-", c=COLOURS.get(method, "k"), label=method)
        axes[1].plot(xs, [p[2] for p in pts], "o-", c=COLOURS.get(method, "k"), label=method)
    for ax, label in [(axes[0], "relative RMSE vs reference (%)"), (axes[1], "ms per frame (log)")]:
        ax.set_xscale("log")
        ax.set_xlabel("distance to the cloud's centroid (m, log; inside drawn at 100 m)")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    axes[1].set_yscale("log")
    fig.suptitle("cumulus27 by distance, defaults, scenes' noise — " + when, fontsize=11)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "accuracy_distance.png"))


if __name__ == "__main__":
    main()
