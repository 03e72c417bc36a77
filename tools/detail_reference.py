#!/usr/bin/env python3
"""The reference detail field of data/scene-format.md ("The detail field", kind "reference"),
written out plainly so that an outside renderer can reproduce Nephele's detailed density.

Evaluated in double precision; Nephele's float evaluation (shaders/detail.glsl) agrees with it to
about 1e-5 (3e-5 checked) at lattice coordinates below 1000 (tests/detail_test.cpp checks the table below).

    python3 tools/detail_reference.py            # prints the check table
    python3 tools/detail_reference.py --mean     # estimates the mean of one octave's noise

Use: detail_value(params, rel) for a point rel (m) from the eye; sigma_t of the scene is
extinction * sum_i density_i * max(1 - q_i (1 + erosion * D)^2, 0)^2, q_i the ellipsoid's squared
unit-space radius (times the noise factor when medium.noise > 0).
"""
import math
import sys

MASK = 0xFFFFFFFF
FADE_ANGLE = 0.004          # rad
GAIN = 0.8
CONTRAST = 6.0
OCTAVE_OFFSET = (0.5698403, 0.7548777, 0.4301597)
SEED = 0x5EED
SEED_STEP = 0x9E3779B9
REFERENCE_MEAN = 0.284        # mu of the reference kind


def pcg_hash(v):
    """PCG-RXS-M-XS 32-bit (Jarzynski & Olano 2020)."""
    state = (v * 747796405 + 2891336453) & MASK
    word = (((state >> ((state >> 28) + 4)) ^ state) * 277803737) & MASK
    return (word >> 22) ^ word


def grad(h, x, y, z):
    b = h >> 28
    u = x if b < 8 else y
    v = y if b < 4 else (x if b in (12, 14) else z)
    return (u if (b & 1) == 0 else -u) + (v if (b & 2) == 0 else -v)


def corner(i, j, k, s, x, y, z):
    h = pcg_hash((i & MASK) ^ pcg_hash((j & MASK) ^ pcg_hash((k & MASK) ^ s)))
    return grad(h, x, y, z)


def quintic(t):
    return t * t * t * (t * (t * 6 - 15) + 10)


def perlin(p, seed):
    """Improved Perlin noise on the unbounded integer lattice."""
    c = [math.floor(a) for a in p]
    f = [a - b for a, b in zip(p, c)]
    i, j, k = c
    s = pcg_hash(seed & MASK)
    n = {}
    for dk in (0, 1):
        for dj in (0, 1):
            for di in (0, 1):
                n[di, dj, dk] = corner(i + di, j + dj, k + dk, s, f[0] - di, f[1] - dj, f[2] - dk)
    u, v, w = (quintic(a) for a in f)
    x00 = n[0, 0, 0] + u * (n[1, 0, 0] - n[0, 0, 0])
    x10 = n[0, 1, 0] + u * (n[1, 1, 0] - n[0, 1, 0])
    x01 = n[0, 0, 1] + u * (n[1, 0, 1] - n[0, 0, 1])
    x11 = n[0, 1, 1] + u * (n[1, 1, 1] - n[0, 1, 1])
    y0 = x00 + v * (x10 - x00)
    y1 = x01 + v * (x11 - x01)
    return y0 + w * (y1 - y0)


def octave_noise(p, octave):
    a = 1 - min(abs(perlin(p, (SEED + octave * SEED_STEP) & MASK)), 1.0)
    a2 = a * a
    a4 = a2 * a2
    return a4 * a4


def octave_count(scale, smallest):
    return int(math.floor(math.log2(scale / smallest) + 1e-9)) + 1


def detail_value(params, rel):
    """D >= 0 at the point rel (m, from the eye). params: dict with origin (eye - drift, m),
    scale and smallest (m)."""
    y = [o + r for o, r in zip(params["origin"], rel)]
    dist = math.sqrt(sum(r * r for r in rel))
    cut = math.log2(params["scale"] / max(FADE_ANGLE * dist, 0.5 * params["smallest"]))
    total = acc = 0.0
    weight, frequency = 1.0, 1.0 / params["scale"]
    for k in range(octave_count(params["scale"], params["smallest"])):
        f = min(max(cut - k, 0.0), 1.0)
        n = REFERENCE_MEAN
        if f > 0:
            p = [a * frequency + k * o for a, o in zip(y, OCTAVE_OFFSET)]
            n = REFERENCE_MEAN + f * (octave_noise(p, k) - REFERENCE_MEAN)
        acc += weight * n
        total += weight
        weight *= GAIN
        frequency *= 2
    return max(0.5 + CONTRAST * (acc / total - REFERENCE_MEAN), 0.0)


# The check table of data/scene-format.md: (origin, rel) -> D, scale 256 m, smallest 1 m.
CHECKS = [
    ((0.0, 0.0, 0.0), (10.0, 0.0, 0.0)),
    ((0.0, -1900.0, 1300.0), (-20.0, 1900.0, 300.0)),
    ((123.5, -45.25, 1000.0), (3.0, 4.0, 5.0)),
    ((-388.8, -412.2, 1646.5), (50.0, -20.0, 7.5)),
    ((5000.0, 5000.0, 2000.0), (-4000.0, -2500.0, -300.0)),
]


def main():
    if "--mean" in sys.argv:
        import random
        rng = random.Random(1)
        vals = [octave_noise([rng.uniform(-50, 50) for _ in range(3)], k) for k in range(4) for _ in range(20000)]
        m = sum(vals) / len(vals)
        print(f"mean {m:.4f}  sd {math.sqrt(sum((v - m) ** 2 for v in vals) / len(vals)):.4f}")
        return
    print("perlin((0.3, 1.7, -2.2), 0x5EED) = %.9f" % perlin((0.3, 1.7, -2.2), SEED))
    for origin, rel in CHECKS:
        d = detail_value({"origin": origin, "scale": 256.0, "smallest": 1.0}, rel)
        print(f"origin {origin} rel {rel}: D = {d:.9f}")


if __name__ == "__main__":
    main()
