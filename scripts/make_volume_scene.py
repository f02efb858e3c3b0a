#!/usr/bin/env python3
"""Writes scenes/mitsuba/volumes/smoke.vol, the density grid of scenes/mitsuba/smoke.xml: a
16^3 single-channel Mitsuba VOL (version 3, float32) over the unit cube, a soft ball of smoke
with a denser twisted plume, values in [0, 1] (the scene's `scale` sets the extinction).

    python3 scripts/make_volume_scene.py
"""
import math
import os
import struct

N = 16


def density(x, y, z):
    r = math.sqrt((x - 0.5) ** 2 + (y - 0.45) ** 2 + (z - 0.5) ** 2)
    ball = max(0.0, 1.0 - r / 0.45)
    angle = 6.0 * y
    px, pz = 0.5 + 0.18 * math.cos(angle), 0.5 + 0.18 * math.sin(angle)
    plume = math.exp(-((x - px) ** 2 + (z - pz) ** 2) / 0.01) * (1.0 - y)
    return min(1.0, 0.6 * ball + 0.8 * plume)


def main():
    out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes", "mitsuba", "volumes", "smoke.vol")
    data = bytearray(b"VOL\x03")
    data += struct.pack("<iiiii", 1, N, N, N, 1)
    data += struct.pack("<6f", 0, 0, 0, 1, 1, 1)
    for k in range(N):
        for j in range(N):
            for i in range(N):
                data += struct.pack("<f", density((i + 0.5) / N, (j + 0.5) / N, (k + 0.5) / N))
    with open(out, "wb") as f:
        f.write(data)
    print(out)


if __name__ == "__main__":
    main()
