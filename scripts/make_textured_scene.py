#!/usr/bin/env python3
"""Writes scenes/mitsuba/textured-glossy.xml and its files (scenes/mitsuba/textured/): a small
room of our own making with every texture path the importer has — a bitmap (PNG, bilinear,
repeat, `to_uv` scale) on a PLY floor with texture coordinates, a checkerboard on a rectangle
and on a rotated analytic sphere, a nearest-filtered bitmap on a rough plastic OBJ sphere with
`vt`, a JPEG-free, licence-free set of pictures generated here — and glossy materials (rough
plastic, rough gold, rough glass). Deterministic: running it again rewrites the same bytes.

    python3 scripts/make_textured_scene.py
"""

import math
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "scenes", "mitsuba")
FILES = os.path.join(OUT, "textured")


def png(path, width, height, pixel):
    """An 8-bit RGB PNG; pixel(x, y) -> (r, g, b) in 0..255, row 0 at the top."""
    rows = b"".join(
        b"\x00" + bytes(c for x in range(width) for c in pixel(x, y)) for y in range(height)
    )

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
    data += chunk(b"IDAT", zlib.compress(rows, 9)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(data)


def tiles(x, y):
    """64 × 64: four tiles with grout, each its own terracotta shade, a darker bevel."""
    tx, ty, lx, ly = x // 32, y // 32, x % 32, y % 32
    if lx < 2 or ly < 2:
        return (200, 196, 186)
    base = [(176, 92, 60), (150, 78, 52), (190, 120, 80), (160, 100, 70)][2 * ty + tx]
    shade = 0.8 if (lx < 5 or ly < 5) else 1.0
    return tuple(int(c * shade) for c in base)


def noise(x, y):
    """16 × 16 coloured cells from a fixed linear congruential sequence."""
    s = (x * 73856093 ^ y * 19349663) & 0xFFFFFFFF
    out = []
    for _ in range(3):
        s = (1103515245 * s + 12345) & 0x7FFFFFFF
        out.append(60 + s % 170)
    return tuple(out)


def floor_ply(path, n=4):
    """An n × n grid on [−1, 1]² (z = 0, facing +z) with u, v per vertex (v up: PLY convention)."""
    verts = [(2 * i / n - 1, 2 * j / n - 1, i / n, j / n) for j in range(n + 1) for i in range(n + 1)]
    faces = []
    for j in range(n):
        for i in range(n):
            a = j * (n + 1) + i
            # Triangles: Mitsuba's ASCII PLY reader takes no larger polygons.
            faces += [(a, a + 1, a + n + 2), (a, a + n + 2, a + n + 1)]
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\ncomment photon-bench: a textured floor\n")
        f.write(f"element vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\n")
        f.write("property float u\nproperty float v\n")
        f.write(f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
        for x, y, u, v in verts:
            f.write(f"{x:g} {y:g} 0 {u:g} {v:g}\n")
        for q in faces:
            f.write("3 " + " ".join(map(str, q)) + "\n")


def sphere_obj(path, slices=32, stacks=16):
    """A unit UV sphere: positions, normals and texture coordinates per vertex."""
    lines = ["# photon-bench: a UV sphere"]
    for j in range(stacks + 1):
        theta = math.pi * j / stacks
        for i in range(slices + 1):
            phi = 2 * math.pi * i / slices
            p = (math.sin(theta) * math.cos(phi), math.cos(theta), math.sin(theta) * math.sin(phi))
            lines.append("v %.6f %.6f %.6f" % p)
            lines.append("vn %.6f %.6f %.6f" % p)
            lines.append("vt %.6f %.6f" % (i / slices, 1 - j / stacks))
    for j in range(stacks):
        for i in range(slices):
            a = j * (slices + 1) + i + 1
            b, c, d = a + 1, a + slices + 2, a + slices + 1
            # At the poles one triangle of each cell has two corners on the pole: left out.
            tris = [(a, b, c)] if j > 0 else []
            if j < stacks - 1:
                tris.append((a, c, d))
            for tri in tris:
                lines.append("f " + " ".join(f"{k}/{k}/{k}" for k in tri))
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


SCENE = """<scene version="3.0.0">
    <!-- photon-bench's glossy, textured scene (scripts/make_textured_scene.py). -->
    <default name="width" value="256"/>
    <default name="height" value="192"/>
    <sensor type="perspective">
        <float name="fov" value="42"/>
        <transform name="to_world"><lookat origin="0, 1.6, 5.2" target="0, 0.7, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="$width"/><integer name="height" value="$height"/>
            <rfilter type="box"/></film>
    </sensor>

    <texture type="checkerboard" id="checks">
        <rgb name="color0" value="0.08, 0.1, 0.3"/>
        <rgb name="color1" value="0.7, 0.7, 0.65"/>
        <transform name="to_uv"><scale x="6" y="4"/></transform>
    </texture>

    <!-- The floor: a bitmap, repeated 3 × 3 over a PLY with texture coordinates. -->
    <shape type="ply">
        <string name="filename" value="textured/floor.ply"/>
        <transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="diffuse">
            <texture type="bitmap" name="reflectance">
                <string name="filename" value="textured/tiles.png"/>
                <transform name="to_uv"><scale x="3" y="3"/></transform>
            </texture>
        </bsdf>
    </shape>

    <!-- The back wall: a checkerboard on a rectangle, two-sided. -->
    <shape type="rectangle">
        <transform name="to_world"><scale x="3" y="1.6"/><translate y="1.6" z="-2.2"/></transform>
        <bsdf type="twosided"><bsdf type="diffuse"><ref name="reflectance" id="checks"/></bsdf></bsdf>
    </shape>

    <!-- Rough plastic over a nearest-filtered bitmap, on an OBJ sphere with vt. -->
    <shape type="obj">
        <string name="filename" value="textured/sphere.obj"/>
        <transform name="to_world"><scale value="0.6"/><rotate y="1" angle="40"/><translate x="-1.2" y="0.6" z="-0.3"/></transform>
        <bsdf type="roughplastic">
            <string name="distribution" value="ggx"/>
            <float name="alpha" value="0.08"/>
            <texture type="bitmap" name="diffuse_reflectance">
                <string name="filename" value="textured/noise.png"/>
                <string name="filter_type" value="nearest"/>
            </texture>
        </bsdf>
    </shape>

    <!-- Rough gold. -->
    <shape type="cube">
        <transform name="to_world"><scale value="0.45"/><rotate y="1" angle="25"/><translate x="1.2" y="0.45" z="-0.6"/></transform>
        <bsdf type="roughconductor"><string name="material" value="Au"/><float name="alpha" value="0.15"/></bsdf>
    </shape>

    <!-- A checkered analytic sphere, turned so that its poles are not up. -->
    <shape type="sphere">
        <transform name="to_world"><rotate x="1" angle="60"/><scale value="0.35"/><translate x="0.15" y="0.35" z="0.9"/></transform>
        <bsdf type="diffuse"><ref name="reflectance" id="checks"/></bsdf>
    </shape>

    <!-- Frosted glass. -->
    <shape type="sphere">
        <point name="center" x="0.2" y="1.45" z="-0.9"/><float name="radius" value="0.3"/>
        <bsdf type="roughdielectric"><float name="alpha" value="0.1"/></bsdf>
    </shape>

    <!-- The light: a rectangle above, facing down. -->
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.7"/><rotate x="1" angle="90"/><translate y="3.4" z="0.3"/></transform>
        <emitter type="area"><rgb name="radiance" value="14, 13, 11"/></emitter>
    </shape>
</scene>
"""


def main():
    os.makedirs(FILES, exist_ok=True)
    png(os.path.join(FILES, "tiles.png"), 64, 64, tiles)
    png(os.path.join(FILES, "noise.png"), 16, 16, noise)
    floor_ply(os.path.join(FILES, "floor.ply"))
    sphere_obj(os.path.join(FILES, "sphere.obj"))
    with open(os.path.join(OUT, "textured-glossy.xml"), "w") as f:
        f.write(SCENE)


if __name__ == "__main__":
    main()
