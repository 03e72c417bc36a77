#!/usr/bin/python3
"""Writes data/scenes/cruise.json and data/scenes/cruise_turn.json: the cruise bench's field
(about 4000 ellipsoids in 150 cumulus, from the cumulus generator) and its two flights, a 60 s
straight-and-level cruise at 70 m/s through and over the field, and a 180-degree turn in 3 s
inside it. Deterministic: run it again and the files come out the same.

    /usr/bin/python3 bench/make_cruise.py data/scenes
"""
import json
import math
import random
import sys

SPEED = 70.0  # m/s


def field(rng):
    """150 cumulus on a jittered 15 x 10 grid, 1.2 km apart (18 x 12 km): clouds about 0.8 km
    across, a fair-weather field of about a third cover, centres at 1300-1600 m."""
    entries = []
    for j in range(10):
        for i in range(15):
            cx = -9000 + 1200 * (i + 0.5) + rng.uniform(-300, 300)
            cy = -6000 + 1200 * (j + 0.5) + rng.uniform(-300, 300)
            cz = rng.uniform(1300, 1600)
            r = rng.uniform(0.7, 1.2)
            entries.append({"type": "cumulus", "center": [round(cx, 1), round(cy, 1), round(cz, 1)],
                            "count": 29, "seed": rng.randrange(1, 1 << 31),
                            "sigma": [round(150 * r, 1), round(150 * r, 1), round(70 * r, 1)],
                            "max_radius": round(110 * r, 1)})
    return entries


def key(t, p, d):
    return {"t": round(t, 3), "position": [round(v, 2) for v in p],
            "look_at": [round(p[k] + 1000 * d[k], 2) for k in range(3)]}


def cruise_path():
    """Along +y at 70 m/s, 60 s: through the cloud tops at 1500 m, then up and over them
    (a shallow climb of 10 m/s from 20 to 60 s, 1900 m at the end)."""
    path = []
    for t in range(0, 61, 5):
        climb = max(0.0, t - 20) * 10.0
        p = (-40.0, -900.0 + SPEED * t, 1500.0 + climb)
        d = (0.0, 1.0, (10.0 / SPEED if t >= 20 else 0.0) - 0.05)
        path.append(key(float(t), p, d))
    return path


def turn_path():
    """1 s straight along +y, a level 180-degree turn to the left in 3 s (radius 70 * 3 / pi m),
    1 s straight back along -y, at 1450 m inside the field."""
    r = SPEED * 3.0 / math.pi
    start = (200.0, 1200.0, 1450.0)
    path = [key(0.0, start, (0.0, 1.0, -0.03))]
    c = (start[0] - r, start[1] + SPEED, start[2])  # the turn's centre, to the left
    for k in range(13):
        a = math.pi * k / 12  # heading turned so far
        t = 1.0 + 3.0 * k / 12
        p = (c[0] + r * math.cos(a), c[1] + r * math.sin(a), c[2])
        d = (-math.sin(a), math.cos(a), -0.03)
        path.append(key(t, p, d))
    end = path[-1]["position"]
    path.append(key(5.0, (end[0], end[1] - SPEED, end[2]), (0.0, -1.0, -0.03)))
    return path


def scene(note, path):
    rng = random.Random(20261202)
    first = path[0]
    return {"cloudscene": 1, "_note": note,
            "camera": {"position": first["position"], "look_at": first["look_at"], "fov_y_deg": 60,
                       "width": 1280, "height": 720},
            "sun": {"direction": [0.35, -0.45, 0.82]},
            "generate": field(rng), "path": path}


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "data/scenes"
    made = {"cruise.json": scene("The cruise bench's field (150 cumulus, about 4000 ellipsoids, bench/make_cruise.py): "
                                 "a 60 s straight-and-level cruise at 70 m/s through the cloud tops and over them.",
                                 cruise_path()),
            "cruise_turn.json": scene("The cruise bench's field (bench/make_cruise.py): a 180-degree turn in 3 s "
                                      "inside it, at 70 m/s.", turn_path())}
    for name, s in made.items():
        with open(f"{out}/{name}", "w") as f:
            f.write(json.dumps(s, indent=1) + "\n")


if __name__ == "__main__":
    main()
