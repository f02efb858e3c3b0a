#!/usr/bin/env python3
"""Writes the two curve files of scenes/mitsuba/curves.xml (this project's own, under its
licence), in Mitsuba 3's text format (per line x y z radius, an empty line between curves):

- curves/zigzag.txt: two linear curves, a zigzag whose radius grows along it (so the cones
  between its spheres tilt) and a short straight rod of constant radius;
- curves/spring.txt: a B-spline helix of 2.5 turns whose radius narrows toward both ends, a
  gentle arc of constant radius, and a short straight tube pointing 25 degrees off the camera, whose
  open end shows that the inside of a B-spline tube is invisible (Embree culls back faces).

Needs only the standard library. Run from the repository's top directory.
"""
import math
import os

OUT = "scenes/mitsuba/curves"


def write(name, curves):
    with open(os.path.join(OUT, name), "w") as f:
        f.write("\n\n".join("\n".join(" ".join(f"{x:.6g}" for x in p) for p in c) for c in curves) + "\n")


def main():
    os.makedirs(OUT, exist_ok=True)
    zigzag = [(-0.9 + 0.3 * i, 0.15 + 0.25 * (i % 2), 0.3 * (i % 3) - 0.3, 0.04 + 0.012 * i) for i in range(7)]
    rod = [(-0.8, 0.08, 0.7), (0.6, 0.08, 0.9)]
    write("zigzag.txt", [zigzag, [(x, y, z, 0.05) for x, y, z in rod]])
    n = 40
    helix = []
    for i in range(n):
        t = i / (n - 1)
        a = 2.5 * 2 * math.pi * t
        r = 0.015 + 0.05 * math.sin(math.pi * t)
        helix.append((0.45 + 0.3 * math.cos(a), 0.15 + 0.9 * t, -0.6 + 0.3 * math.sin(a), r))
    arc = [(-0.9 + 0.25 * i, 0.6 + 0.3 * math.sin(0.5 * i), -0.9, 0.035) for i in range(6)]
    view = (0.2 + 1.5, 1.2, 2.9)
    norm = math.sqrt(sum(c * c for c in view))
    view = tuple(c / norm for c in view)
    pipe = [tuple(b + 0.15 * i * v for b, v in zip((-0.45, 0.6, 0.3), view)) + (0.12,) for i in range(5)]
    write("spring.txt", [helix, arc, pipe])


if __name__ == "__main__":
    main()
