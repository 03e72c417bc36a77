#!/usr/bin/python3
"""Chart of `nephele bench --flicker`: frame-to-frame change along each camera path, one
panel per path, one line per method and setting (the exact model's is the reference).
Usage: /usr/bin/python3 bench/plot_flicker.py FLICKER_SERIES.csv OUT.png "WHEN"
(Debian's python3-matplotlib: call /usr/bin/python3, not the python3 first on PATH.)"""
import csv
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    rows = list(csv.DictReader(open(sys.argv[1])))
    seqs = defaultdict(lambda: defaultdict(list))
    for r in rows:
        seqs[r["sequence"]][r["method"] + " " + r["setting"]].append((int(r["frame"]), float(r["change"])))
    fig, axes = plt.subplots(len(seqs), 1, figsize=(9, 3.2 * len(seqs)), dpi=100, squeeze=False)
    for ax, (name, runs) in zip(axes[:, 0], seqs.items()):
        for label, pts in runs.items():
            style = "k-" if "reference" in label else "-"
            ax.plot([p[0] for p in pts], [p[1] for p in pts], style, lw=1.6 if "reference" in label else 1,
                    label=label)
        ax.set_title(name, fontsize=10)
        ax.set_xlabel("frame")
        ax.set_ylabel("mean |change| from the previous frame")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("Nephele: frame-to-frame change along camera paths — " + sys.argv[3], fontsize=10)
    fig.tight_layout()
    fig.savefig(sys.argv[2])


if __name__ == "__main__":
    main()
