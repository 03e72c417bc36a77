#!/usr/bin/python3
"""Chart of `nephele bench`: ms per frame against ellipsoid count (log-log) for the
compositor, the paper's one-draw-per-ellipsoid baseline, and the fill-rate floor.
Usage: /usr/bin/python3 bench/plot_bench.py BENCH.csv OUT.png "WHEN"
(Debian's python3-matplotlib: call /usr/bin/python3, not the python3 first on PATH.)"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    rows = list(csv.DictReader(open(sys.argv[1])))
    n = [int(r["ellipsoids"]) for r in rows]
    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=100)
    for key, label, style in [("ms", "compositor (instanced, colour matrix in the composite)", "o-"),
                              ("baseline_ms", "baseline: one draw per ellipsoid, separate colour-matrix pass", "s--"),
                              ("separate_pass_ms", "instanced, separate colour-matrix pass", "d-"),
                              ("weighted_composite_ms", "instanced, weighted composite (--composite weighted)", "x-"),
                              ("detail_ms", "compositor with the detail on (erosion 1.5)", "v-"),
                              ("floor_ms", "floor: pixel work alone", "^:")]:
        if key in rows[0]:  # older CSVs lack the later columns
            ax.plot(n, [float(r[key]) for r in rows], style, label=label)
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xlabel("ellipsoids")
    ax.set_ylabel("ms per frame (median)")
    ax.set_title("Nephele ellipsoid compositor, 1280x720 — " + sys.argv[3], fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(sys.argv[2])


if __name__ == "__main__":
    main()
