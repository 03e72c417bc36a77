#!/usr/bin/python3
"""Chart of `nephele bench --weather`: ms per frame along the flight for SkyRenderer's update +
draw, for the one-call render() of before and for the first frame drawn again (the same work every
frame), the weather changes marked, and 1.5x the median.
Usage: /usr/bin/python3 bench/plot_weather.py WEATHER_BENCH.csv OUT.png "WHEN" "WxH"
(Debian's python3-matplotlib: call /usr/bin/python3, not the python3 first on PATH.)"""
import csv
import statistics
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    rows = list(csv.DictReader(open(sys.argv[1])))
    frame = [int(r["frame"]) for r in rows]
    ms = [float(r["ms"]) for r in rows]
    before = [float(r["before_ms"]) for r in rows]
    steady = [float(r["steady_ms"]) for r in rows]
    fig, ax = plt.subplots(figsize=(8, 4.5), dpi=100)
    ax.plot(frame, before, "-", color="tab:red", alpha=0.6, label="before: render()")
    ax.plot(frame, steady, "-", color="grey", alpha=0.6, label="steady: the first frame again")
    ax.plot(frame, ms, "-", color="tab:blue", label="update + draw")
    ax.axhline(1.5 * statistics.median(ms), color="tab:blue", ls=":", label="1.5 × median (the target)")
    for r in rows:
        if r["event"]:
            ax.axvline(int(r["frame"]), color="grey", alpha=0.4)
            ax.annotate(r["event"], (int(r["frame"]), 0.98), xycoords=("data", "axes fraction"), rotation=90,
                        fontsize=6, va="top", ha="right", color="dimgrey")
    ax.set_yscale("log")
    ax.set_xlabel("frame")
    ax.set_ylabel("ms per frame")
    ax.set_title("Nephele live weather, %s — %s" % (sys.argv[4], sys.argv[3]), fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(sys.argv[2])


if __name__ == "__main__":
    main()
