#!/usr/bin/env python3
"""Writes the two small maps of scenes/mitsuba/{normalmap,bumpmap}-tiles.xml (this project's own,
under its licence): 64 x 64 PNGs of 4 x 4 bevelled tiles, read raw.

- textures/tiles_heights.png: a tile's height is 1 on its plateau, falling linearly to 0 over a
  bevel of 3 texels at its border, plus a tilt of its own (up to 0.15 across the tile);
- textures/tiles_normals.png: the normals of that height field at slope scale 0.15 per texel
  (steep at the bevels, gently tilted on the plateaus), encoded as (n + 1) / 2.

Needs numpy and mitsuba (for PNG writing). Run from the repository's top directory.
"""
import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
N, TILES, BEVEL = 64, 4, 3.0
size = N // TILES
rng = np.random.default_rng(7)
tilt = rng.uniform(-0.15, 0.15, size=(TILES, TILES, 2))
y, x = np.mgrid[0:N, 0:N] + 0.5
tx, ty = (x // size).astype(int), (y // size).astype(int)
fx, fy = x - tx * size, y - ty * size
edge = np.minimum(np.minimum(fx, size - fx), np.minimum(fy, size - fy))
h = np.clip(edge / BEVEL, 0.0, 1.0)
h = h * (0.8 + tilt[ty, tx, 0] * (fx / size - 0.5) + tilt[ty, tx, 1] * (fy / size - 0.5))
h = np.clip(h, 0.0, 1.0)
gy, gx = np.gradient(h)
n = np.stack([-gx * 3.0, -gy * 3.0, np.ones_like(h)], axis=-1)
n /= np.linalg.norm(n, axis=-1, keepdims=True)

def png(path, img):
    mi.Bitmap(np.ascontiguousarray(img.astype(np.float32))).convert(
        mi.Bitmap.PixelFormat.RGB if img.ndim == 3 else mi.Bitmap.PixelFormat.Y,
        mi.Struct.Type.UInt8, srgb_gamma=False).write(path)

png("scenes/mitsuba/textures/tiles_heights.png", h)
png("scenes/mitsuba/textures/tiles_normals.png", (n + 1.0) / 2.0)
