#!/usr/bin/env python3
"""The ten `[[user_paths]]` of scenes/box.toml: the two caustics under the glass ball.

Fan, Chenney & Lai 2005 (section 6) use ten user paths in their Box scene, five for each
caustic under the glass ball: the large one of light refracted straight through the ball, and
the small one of light reflected by the mirror wall and then refracted through the ball. This
script traces them exactly (ray-sphere intersections and Snell's law in double precision) and
prints the TOML blocks pasted into scenes/box.toml:

    python3 scripts/box_user_paths.py

Each path: a point on the light, [a point on the mirror wall x = 0,] the entry point on the
glass sphere, the exit point, and the point where the refracted ray meets the floor y = 0.
The geometry below must match scenes/box.toml; tests/mps_scenes.rs checks the paths against
the loaded scene (hits, materials, reflection and refraction directions).
"""
import math

LIGHT_Y = 0.539                 # the light quad's plane (1 mm below the ceiling y = 0.54)
LIGHT_C = (0.36, 0.28)          # its centre (x, z); size 0.13 x 0.105
GLASS_C = (0.21, 0.10, 0.20)    # glass sphere centre and radius
GLASS_R = 0.10
IOR = 1.5
MIRROR_C = (0.50, 0.11, 0.40)   # mirror sphere, to check that nothing hits it
MIRROR_R = 0.11
BOX = (0.72, 0.54, 0.56)        # interior x, y, z extents


def add(a, b): return tuple(x + y for x, y in zip(a, b))
def sub(a, b): return tuple(x - y for x, y in zip(a, b))
def mul(a, s): return tuple(x * s for x in a)
def dot(a, b): return sum(x * y for x, y in zip(a, b))
def norm(a): return mul(a, 1.0 / math.sqrt(dot(a, a)))


def sphere_hits(o, d, c, r):
    """Both ray parameters where o + t d meets the sphere (d unit), or None."""
    oc = sub(o, c)
    b = dot(oc, d)
    disc = b * b - (dot(oc, oc) - r * r)
    if disc < 0:
        return None
    s = math.sqrt(disc)
    return (-b - s, -b + s)


def refract(d, n, eta):
    """Refracts unit d at unit normal n (n opposes d); eta = n_from / n_to."""
    cos_i = -dot(d, n)
    k = 1 - eta * eta * (1 - cos_i * cos_i)
    assert k >= 0, "total internal reflection"
    return norm(add(mul(d, eta), mul(n, eta * cos_i - math.sqrt(k))))


def through_glass(p, d):
    """From p along unit d: entry, exit and floor points through the glass sphere."""
    t0, _ = sphere_hits(p, d, GLASS_C, GLASS_R)
    assert t0 > 0
    entry = add(p, mul(d, t0))
    n1 = norm(sub(entry, GLASS_C))
    d1 = refract(d, n1, 1 / IOR)
    _, t1 = sphere_hits(entry, d1, GLASS_C, GLASS_R)
    exit_ = add(entry, mul(d1, t1))
    n2 = norm(sub(exit_, GLASS_C))
    d2 = refract(d1, mul(n2, -1), IOR)
    assert d2[1] < 0, "the exit ray must go down to the floor"
    floor = add(exit_, mul(d2, -exit_[1] / d2[1]))
    assert 0 < floor[0] < BOX[0] and 0 < floor[2] < BOX[2], floor
    hits = sphere_hits(exit_, d2, MIRROR_C, MIRROR_R)
    assert hits is None or hits[1] < 0 or hits[0] > math.dist(exit_, floor)
    return [entry, exit_, floor]


def fmt(p):
    return "[" + ", ".join(f"{0.0 if abs(x) < 5e-7 else x:.6f}" for x in p) + "]"


def block(points, cone, comment):
    pts = ", ".join(fmt(p) for p in points)
    return f"[[user_paths]] # {comment}\npoints = [{pts}]\ncone_deg = {cone}\n"


def main():
    # Light points: the centre and four points toward the corners; aim points on the ball:
    # the centre and four offsets of 0.4 R (0.3 R via the mirror) across the beam.
    lights = [(0.0, 0.0), (0.04, 0.03), (-0.04, 0.03), (-0.04, -0.03), (0.04, -0.03)]
    offsets = [(0.0, 0.0), (0.4, 0.0), (0.0, 0.4), (-0.4, 0.0), (0.0, -0.4)]
    out = []
    for (lx, lz), (ox, oz) in zip(lights, offsets):
        lp = (LIGHT_C[0] + lx, LIGHT_Y, LIGHT_C[1] + lz)
        aim = (GLASS_C[0] + ox * GLASS_R, GLASS_C[1], GLASS_C[2] + oz * GLASS_R)
        d = norm(sub(aim, lp))
        out.append(block([lp] + through_glass(lp, d), 5.0, "light -> glass ball -> floor"))
    for (lx, lz), (ox, oz) in zip(lights, offsets):
        lp = (LIGHT_C[0] + lx, LIGHT_Y, LIGHT_C[1] + lz)
        aim = (GLASS_C[0] + 0.75 * ox * GLASS_R, GLASS_C[1], GLASS_C[2] + 0.75 * oz * GLASS_R)
        image = (-aim[0], aim[1], aim[2])  # the aim point seen in the mirror x = 0
        d = norm(sub(image, lp))
        m = add(lp, mul(d, -lp[0] / d[0]))
        assert 0 < m[1] < BOX[1] and 0 < m[2] < BOX[2], m
        d_m = (-d[0], d[1], d[2])
        out.append(block([lp, m] + through_glass(m, d_m), 2.0, "light -> mirror wall -> glass ball -> floor"))
    print("\n".join(out), end="")


if __name__ == "__main__":
    main()
