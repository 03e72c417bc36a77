#!/usr/bin/python3
"""The machine's own floor for even frames: the same work every frame, timed. Each frame, P
processes (one per core by default) each run the same fixed arithmetic, and the frame ends when
all are done, as a frame ends when its last thread is. Nothing varies but the machine, so the
worst frame over the median is what the machine alone does to a renderer's "every frame within
1.5x the median" (docs/embedding.md, the weather bench). Run it beside what loads the machine
(a build), as the bench is run.

Usage: tools/even_frames.py [FRAMES] [MS_PER_FRAME] [PROCESSES]   (defaults: 200, 100, cores)
"""
import multiprocessing
import os
import statistics
import sys
import time


def work(units):
    x = 0
    for i in range(units):
        x = (x * 31 + i) & 0xFFFF
    return x


def worker(units, frames, barrier):
    for _ in range(frames):
        barrier.wait()
        work(units)
        barrier.wait()


def main():
    try:
        frames = int(sys.argv[1]) if len(sys.argv) > 1 else 200
        ms = float(sys.argv[2]) if len(sys.argv) > 2 else 100.0
        processes = int(sys.argv[3]) if len(sys.argv) > 3 else os.cpu_count()
    except ValueError:
        sys.exit(__doc__)
    if not (10 <= frames <= 100000) or not (1 <= ms <= 10000) or not (1 <= processes <= 1024):
        sys.exit("even_frames.py: FRAMES in [10, 100000], MS_PER_FRAME in [1, 10000], PROCESSES in [1, 1024]")
    # Units of work that take about `ms` on this machine, measured alone first.
    start = time.perf_counter()
    work(200000)
    units = max(1000, int(200000 * ms / (1e3 * (time.perf_counter() - start))))
    barrier = multiprocessing.Barrier(processes + 1)
    pool = [multiprocessing.Process(target=worker, args=(units, frames, barrier)) for _ in range(processes)]
    for p in pool:
        p.start()
    times = []
    for _ in range(frames):
        barrier.wait()
        t0 = time.perf_counter()
        barrier.wait()
        times.append(1e3 * (time.perf_counter() - t0))
    for p in pool:
        p.join()
    median = statistics.median(times)
    worst = max(times)
    over = sum(t > 1.5 * median for t in times)
    p95 = sorted(times)[int(0.95 * (len(times) - 1))]
    print(f"{frames} frames of the same work on {processes} processes: median {median:.1f} ms, "
          f"95th percentile {p95 / median:.2f}x, worst {worst:.1f} ms = {worst / median:.2f}x the median, "
          f"{over} frames over 1.5x")


if __name__ == "__main__":
    main()
