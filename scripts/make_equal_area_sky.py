#!/usr/bin/env python3
"""Writes scenes/pbrt/textures/sky-equal-area.png: a procedural sky for the pbrt-v4 still life
(CC0, photon-bench's own), in pbrt-v4's equal-area octahedral square layout (light space +z up;
Clarberg's mapping as pbrt-v4's EqualAreaSquareToSphere), 8-bit sRGB.

A blue zenith fading to a pale horizon, a darker ground below it, and a soft bright patch
around the sun direction. Run: python3 scripts/make_equal_area_sky.py [N]  (default N = 256).
"""
import math
import sys

import numpy as np
from PIL import Image


def square_to_sphere(u, v):
    u, v = 2 * u - 1, 2 * v - 1
    up, vp = abs(u), abs(v)
    signed = 1 - (up + vp)
    r = 1 - abs(signed)
    phi = (1 if r == 0 else (vp - up) / r + 1) * math.pi / 4
    z = math.copysign(1 - r * r, signed)
    s = r * math.sqrt(max(0.0, 2 - r * r))
    return (math.copysign(math.cos(phi), u) * s, math.copysign(math.sin(phi), v) * s, z)


def radiance(d):
    x, y, z = d
    zenith, horizon, ground = np.array([0.25, 0.42, 0.85]), np.array([0.95, 0.9, 0.82]), np.array([0.3, 0.27, 0.24])
    if z >= 0:
        t = z ** 0.5
        c = (1 - t) * horizon + t * zenith
    else:
        c = ground * (1 - 0.5 * min(1.0, -z))
    sun = np.array([0.5, -0.35, 0.79])
    sun /= np.linalg.norm(sun)
    c = c + np.array([1.0, 0.95, 0.85]) * math.exp(-(1 - (x * sun[0] + y * sun[1] + z * sun[2])) / 0.01)
    return np.clip(c, 0, 1)


def to_srgb(c):
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 256
    img = np.zeros((n, n, 3))
    for y in range(n):
        for x in range(n):
            img[y, x] = radiance(square_to_sphere((x + 0.5) / n, (y + 0.5) / n))
    out = (to_srgb(img) * 255 + 0.5).astype(np.uint8)
    Image.fromarray(out).save("scenes/pbrt/textures/sky-equal-area.png")


if __name__ == "__main__":
    main()
