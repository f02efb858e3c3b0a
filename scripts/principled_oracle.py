#!/usr/bin/env python3
"""Prints Mitsuba 3's `principled` and `principledthin` values (scalar_rgb) at direction pairs,
for the oracle test in src/bsdf/principled_tests.rs (`principled_models_match_mitsuba`).
Mitsuba's `eval` includes the cosine of the outgoing direction; the printed f divides it out, so
it is f_s as photon-bench defines it. Mitsuba's wi is our wo (toward the viewer), its wo our wi.
Pairs: uniform random directions, and directions near the mirror and refraction directions (and,
for the thin sheet, near straight through), so that the glossy lobes are exercised; both
transport modes.

Usage: python3 scripts/principled_oracle.py > tests/data/principled_oracle.txt
"""
import math

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")


def rgb(*c):
    return {"type": "rgb", "value": list(c)}


MODELS = {
    "principled_defaults": {"type": "principled"},
    "principled_plain": {"type": "principled", "base_color": rgb(0.8, 0.3, 0.2), "roughness": 0.4},
    "principled_everything": {
        "type": "principled", "base_color": rgb(0.9, 0.6, 0.2), "metallic": 0.7, "specular": 0.6,
        "roughness": 0.3, "spec_tint": 0.4, "anisotropic": 0.5, "sheen": 0.3, "sheen_tint": 0.2,
        "clearcoat": 0.6, "clearcoat_gloss": 0.3, "spec_trans": 0.4,
    },
    "principled_glass": {"type": "principled", "base_color": rgb(0.9, 0.9, 0.7), "spec_trans": 1.0,
                         "roughness": 0.2, "eta": 1.33},
    "principled_sheen_flat": {"type": "principled", "base_color": rgb(0.2, 0.5, 0.3), "roughness": 0.8,
                              "flatness": 0.7, "sheen": 1.0, "sheen_tint": 0.8, "spec_tint": 0.5},
    "principled_clearcoat": {"type": "principled", "base_color": rgb(0.4, 0.4, 0.9), "roughness": 0.6,
                             "metallic": 0.2, "clearcoat": 1.0, "clearcoat_gloss": 0.9,
                             "clearcoat_sampling_rate": 0.5, "main_specular_sampling_rate": 2.0},
    "principled_twosided": {"type": "twosided", "bsdf": {
        "type": "principled", "base_color": rgb(0.8, 0.3, 0.2), "roughness": 0.4, "metallic": 0.3}},
    "thin_everything": {
        "type": "principledthin", "base_color": rgb(0.7, 0.4, 0.3), "roughness": 0.3, "spec_trans": 0.5,
        "diff_trans": 0.8, "eta": 1.4, "spec_tint": 0.3, "sheen": 0.4, "sheen_tint": 0.5, "flatness": 0.3,
        "anisotropic": 0.4,
    },
    "thin_translucent": {"type": "principledthin", "diff_trans": 1.5, "spec_trans": 0.2,
                         "diffuse_reflectance_sampling_rate": 0.5},
}

ETA = {"principled_glass": 1.33, "thin_everything": 1.4}


def normalize(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def reflect(w):
    return np.array([-w[0], -w[1], w[2]])


def refract(w, eta):
    eta = eta if w[2] > 0 else 1.0 / eta
    cos_i = abs(w[2])
    sin2_t = (1 - cos_i * cos_i) / (eta * eta)
    if sin2_t >= 1:
        return reflect(w)
    cos_t = math.sqrt(1 - sin2_t)
    return np.array([-w[0] / eta, -w[1] / eta, -math.copysign(cos_t, w[2])])


def pairs(name, rng):
    eta = ETA.get(name, 2.0 / (1.0 - math.sqrt(0.08 * 0.5)) - 1.0)
    out = []
    for _ in range(5):
        wo = normalize(rng.normal(size=3))
        if name.startswith("principled") and rng.uniform() < 0.6:
            wo[2] = abs(wo[2])
        candidates = [
            normalize(rng.normal(size=3)),
            normalize(rng.normal(size=3)),
            normalize(reflect(wo) + 0.15 * rng.normal(size=3)),
            normalize(refract(wo, eta) + 0.15 * rng.normal(size=3)),
            normalize(-wo + 0.2 * rng.normal(size=3)),
        ]
        out += [(wo, wi) for wi in candidates]
    return out


def f32(w):
    return " ".join(repr(float(np.float32(x))) for x in w)


print(f"# Mitsuba {mi.__version__} scalar_rgb, written by scripts/principled_oracle.py:")
print("# model mode wo.x wo.y wo.z wi.x wi.y wi.z f.r f.g f.b pdf")
rng = np.random.default_rng(7)
for name, props in MODELS.items():
    bsdf = mi.load_dict(props)
    for wo, wi in pairs(name, rng):
        wo, wi = np.float32(wo), np.float32(wi)
        for mode in ["Radiance", "Importance"]:
            ctx = mi.BSDFContext(getattr(mi.TransportMode, mode))
            si = mi.SurfaceInteraction3f()
            si.n = [0, 0, 1]
            si.sh_frame = mi.Frame3f(si.n)
            si.wi = [float(x) for x in wo]
            value, pdf = bsdf.eval_pdf(ctx, si, [float(x) for x in wi])
            c = abs(float(wi[2]))
            f = [value[i] / c for i in range(3)]
            print(f"{name} {mode.lower()} {f32(wo)} {f32(wi)} {f[0]:.7e} {f[1]:.7e} {f[2]:.7e} {pdf:.7e}")
