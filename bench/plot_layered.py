#!/usr/bin/python3
"""Chart of `nephele bench --layered`: ms per frame against the annulus count N (log-log), one
line per layer extent, for the layered sky as shipped, before its speed work, and its floor.
Usage: /usr/bin/python3 bench/plot_layered.py LAYERED_BENCH.csv OUT.png "WHEN" "WxH"
(Debian's python3-matplotlib: call /usr/bin/python3, not the python3 first on PATH.)"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    rows = list(csv.DictReader(open(sys.argv[1])))
    extents = sorted({float(r["extent_m"]) for r in rows})
    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=100)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, e in enumerate(extents):
        sub = [r for r in rows if float(r["extent_m"]) == e]
        n = [int(r["layers"]) for r in sub]
        c = colours[i % len(colours)]
        km = "%.0f km" % (e / 1000)
        ax.plot(n, [float(r["ms"]) for r in sub], "o-", color=c, label="layered, " + km)
        ax.plot(n, [float(r["before_ms"]) for r in sub], "s--", color=c, alpha=0.6, label="before the speed work, " + km)
        ax.plot(n, [float(r["floor_ms"]) for r in sub], "^:", color=c, alpha=0.8, label="floor, " + km)
    ax.set_xscale("log", base=2)
    counts = sorted({int(r["layers"]) for r in rows})
    ax.set_xticks(counts)
    ax.set_xticklabels([str(c) for c in counts])
    ax.minorticks_off()
    ax.set_yscale("log")
    ax.set_xlabel("annuli per layer (N)")
    ax.set_ylabel("ms per frame (median)")
    ax.set_title("Nephele layered sky, %s — %s" % (sys.argv[4], sys.argv[3]), fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(sys.argv[2])


if __name__ == "__main__":
    main()
