#!/usr/bin/python3
"""A strip of frames from a recorded flight (`nephele fly ... --record DIR`), side by side.

usage: apps/fly/plot_strip.py DIR OUT.png [--frames 0,24,48,...] [--columns N]
"""
import argparse
import os
import sys

import matplotlib.image as mpimg
import numpy as np


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir")
    ap.add_argument("out")
    ap.add_argument("--frames", default="", help="frame numbers (default: six evenly spaced)")
    ap.add_argument("--columns", type=int, default=0, help="frames per row (default: all in one row)")
    a = ap.parse_args()
    names = sorted(n for n in os.listdir(a.dir) if n.startswith("frame_") and n.endswith(".png"))
    if not names:
        sys.exit(f"plot_strip: no frame_NNNN.png in {a.dir}")
    picks = [int(k) for k in a.frames.split(",")] if a.frames else \
        [round(i * (len(names) - 1) / 5) for i in range(6)]
    for k in picks:
        if not 0 <= k < len(names):
            sys.exit(f"plot_strip: --frames: no frame {k} (the flight has {len(names)})")
    images = [mpimg.imread(os.path.join(a.dir, names[k]))[..., :3] for k in picks]
    cols = a.columns or len(images)
    h, w, _ = images[0].shape
    gap = 4
    rows = (len(images) + cols - 1) // cols
    sheet = np.ones((rows * h + (rows - 1) * gap, cols * w + (cols - 1) * gap, 3), dtype=np.float32)
    for i, img in enumerate(images):
        r, c = divmod(i, cols)
        sheet[r * (h + gap):r * (h + gap) + h, c * (w + gap):c * (w + gap) + w] = img
    mpimg.imsave(a.out, sheet)
    print(f"plot_strip: wrote {a.out} (frames {', '.join(map(str, picks))})")


if __name__ == "__main__":
    main()
