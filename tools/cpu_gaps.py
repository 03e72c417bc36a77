#!/usr/bin/python3
"""Times the gaps a busy loop sees: N processes each read the clock in a loop for S seconds and
count the gaps over 20 ms between two readings, when the process did not run. On a machine of
its own a loop alone on its core sees none; a loop that sees gaps while the guest's scheduler
ran nothing else in its place (check with `perf sched record` / `perf sched timehist`) lost
the time outside the guest: a virtual machine's host took the core (docs/embedding.md, "Turns").

Usage: tools/cpu_gaps.py [SECONDS] [PROCESSES]   (defaults: 10 s, one process per core)
"""
import multiprocessing
import os
import sys
import time


def loop(seconds, out):
    gaps, worst, lost = 0, 0.0, 0.0
    last = start = time.monotonic()
    while last - start < seconds:
        now = time.monotonic()
        gap = now - last
        if gap > 0.020:
            gaps, worst, lost = gaps + 1, max(worst, gap), lost + gap
        last = now
    out.put((gaps, worst, lost))


def main():
    try:
        seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 10.0
        processes = int(sys.argv[2]) if len(sys.argv) > 2 else os.cpu_count()
    except ValueError:
        sys.exit(__doc__)
    if not (0 < seconds <= 3600) or not (1 <= processes <= 1024):
        sys.exit("cpu_gaps.py: SECONDS must be in (0, 3600] and PROCESSES in [1, 1024]")
    out = multiprocessing.Queue()
    workers = [multiprocessing.Process(target=loop, args=(seconds, out)) for _ in range(processes)]
    for w in workers:
        w.start()
    results = [out.get() for _ in workers]
    for w in workers:
        w.join()
    for i, (gaps, worst, lost) in enumerate(results):
        print(f"loop {i}: {gaps} gaps over 20 ms in {seconds:g} s, the longest {1e3 * worst:.1f} ms, "
              f"{100 * lost / seconds:.1f}% of the time lost")


if __name__ == "__main__":
    main()
