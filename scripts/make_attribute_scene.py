#!/usr/bin/env python3
"""Writes the two PLY meshes of scenes/mitsuba/mesh-attributes.xml (this project's own, under its
licence), ASCII, with attributes as Mitsuba 3 reads them:

- attributes/ball.ply: a coarse UV sphere (12 x 6 segments, unit radius, vertex normals) whose vertices
  carry a colour field that changes a lot across a triangle (so that interpolating
  it wrongly shows) as `color_0`, `color_1`, `color_2` (Mitsuba's `vertex_color`);
- attributes/tiles.ply: a 6 x 6 grid of tiles in the plane z = 0 over [-1, 1]^2, each tile two
  triangular PLY faces with the tile's colour as float `r`, `g`, `b` (Mitsuba's `face_color`),
  drawn from a seeded generator. (Triangles: Mitsuba 3.9.1's ASCII PLY reader refuses faces of
  four corners.)

Needs only the standard library. Run from the repository's top directory.
"""
import math
import random

OUT = "scenes/mitsuba/attributes"


def ball():
    nu, nv = 12, 6
    verts, faces = [], []
    for j in range(nv + 1):
        theta = math.pi * j / nv
        for i in range(nu + 1):
            phi = 2 * math.pi * i / nu
            n = (math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta))
            c = (0.5 + 0.45 * math.sin(5 * n[0] + 2 * n[2]), 0.5 + 0.45 * math.cos(4 * n[1] + 1), 0.5 + 0.45 * math.sin(3 * n[2] - n[0]))
            verts.append((n, n, c))
    for j in range(nv):
        for i in range(nu):
            a, b = j * (nu + 1) + i, j * (nu + 1) + i + 1
            c, d = a + nu + 1, b + nu + 1
            if j > 0:
                faces.append((a, c, b))
            if j < nv - 1:
                faces.append((b, c, d))
    lines = ["ply", "format ascii 1.0", f"element vertex {len(verts)}"]
    lines += [f"property float {p}" for p in ("x", "y", "z", "nx", "ny", "nz", "color_0", "color_1", "color_2")]
    lines += [f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    lines += [" ".join(f"{x:.6f}" for x in p + n + c) for p, n, c in verts]
    lines += ["3 " + " ".join(map(str, f)) for f in faces]
    return "\n".join(lines) + "\n"


def tiles():
    rng = random.Random(11)
    k = 6
    verts = [(-1 + 2 * i / k, -1 + 2 * j / k, 0.0) for j in range(k + 1) for i in range(k + 1)]
    faces = []
    for j in range(k):
        for i in range(k):
            a = j * (k + 1) + i
            colour = tuple(round(rng.uniform(0.1, 0.9), 4) for _ in range(3))
            faces.append(((a, a + 1, a + k + 2), colour))
            faces.append(((a, a + k + 2, a + k + 1), colour))
    lines = ["ply", "format ascii 1.0", f"element vertex {len(verts)}"]
    lines += [f"property float {p}" for p in ("x", "y", "z")]
    lines += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
    lines += [f"property float {p}" for p in ("r", "g", "b")]
    lines += ["end_header"]
    lines += [" ".join(f"{x:.6f}" for x in v) for v in verts]
    lines += ["3 " + " ".join(map(str, f)) + " " + " ".join(map(str, c)) for f, c in faces]
    return "\n".join(lines) + "\n"


with open(f"{OUT}/ball.ply", "w") as f:
    f.write(ball())
with open(f"{OUT}/tiles.ply", "w") as f:
    f.write(tiles())
