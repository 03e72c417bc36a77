#!/usr/bin/python3
"""Chart of `nephele bench --cruise`: per flight, ms per frame with --reuse on and off, and the
PSNR of each reuse frame against the fresh one (40 dB, the target, marked).
Usage: /usr/bin/python3 bench/plot_cruise.py CRUISE_BENCH.csv OUT.png "WHEN" "WxH"
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
    flights = []
    for r in rows:
        if r["flight"] not in flights:
            flights.append(r["flight"])
    fig, axes = plt.subplots(2, len(flights), figsize=(3.2 * len(flights), 5.5), dpi=100, squeeze=False)
    for k, name in enumerate(flights):
        fr = [r for r in rows if r["flight"] == name]
        x = [int(r["frame"]) for r in fr]
        ax = axes[0][k]
        ax.plot(x, [float(r["off_ms"]) for r in fr], "-", color="tab:red", alpha=0.7, lw=0.8,
                label="reuse off, cloud LOD off")
        alone = [(int(r["frame"]), float(r["reuse_alone_ms"])) for r in fr if r.get("reuse_alone_ms")]
        if alone:
            ax.plot([a for a, _ in alone], [b for _, b in alone], "-", color="tab:orange", alpha=0.7, lw=0.8,
                    label="reuse on, cloud LOD off")
        ax.plot(x, [float(r["on_ms"]) for r in fr], "-", color="tab:blue", lw=0.8, label="auto: reuse on, cloud LOD on")
        ax.axhline(100, color="grey", ls=":", lw=0.8, label="100 ms (10 fps)")
        ax.set_yscale("log")
        ax.set_title(name, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        if k == 0:
            ax.set_ylabel("ms per frame")
            ax.legend(fontsize=7)
        ax = axes[1][k]
        ax.plot(x, [min(float(r["psnr_db"]), 80) for r in fr], "-", color="tab:green", lw=0.8)
        ax.axhline(40, color="tab:red", ls=":", lw=0.8)
        ax.set_xlabel("frame")
        ax.grid(True, alpha=0.3)
        if k == 0:
            ax.set_ylabel("PSNR vs fresh (dB)")
    fig.suptitle("Nephele tiles that last, cloud impostors and the far field reused, %s — %s" % (sys.argv[4], sys.argv[3]), fontsize=10)
    fig.tight_layout()
    fig.savefig(sys.argv[2])


if __name__ == "__main__":
    main()
