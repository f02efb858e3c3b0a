#!/usr/bin/env python3
"""Prints Mitsuba 3's BSDF values (scalar_rgb) at fixed direction pairs, for the oracle test in
src/bsdf/microfacet_tests.rs (`microfacet_models_match_mitsuba`). Mitsuba's `eval` includes the
cosine of the outgoing direction; the printed f divides it out, so it is f_s as photon-bench
defines it. Mitsuba's wi is our wo (toward the viewer), its wo our wi.

Usage: python3 scripts/bsdf_oracle.py
"""
import math

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

MODELS = {
    "conductor_au_ggx_0.3": {"type": "roughconductor", "material": "Au", "distribution": "ggx", "alpha": 0.3},
    "conductor_beckmann_aniso": {"type": "roughconductor", "distribution": "beckmann", "alpha_u": 0.05, "alpha_v": 0.3},
    "dielectric_ggx_0.2": {"type": "roughdielectric", "distribution": "ggx", "alpha": 0.2, "int_ior": 1.5, "ext_ior": 1.0},
    "dielectric_beckmann_0.4": {"type": "roughdielectric", "distribution": "beckmann", "alpha": 0.4, "int_ior": 1.33, "ext_ior": 1.0},
    "plastic_ggx_0.1": {"type": "roughplastic", "distribution": "ggx", "alpha": 0.1, "int_ior": 1.49, "ext_ior": 1.0,
                        "diffuse_reflectance": {"type": "rgb", "value": [0.5, 0.3, 0.1]}},
    "plastic_beckmann_0.3_nonlinear": {"type": "roughplastic", "distribution": "beckmann", "alpha": 0.3, "int_ior": 1.49,
                                       "ext_ior": 1.0, "nonlinear": True,
                                       "diffuse_reflectance": {"type": "rgb", "value": [0.8, 0.8, 0.8]}},
}


def unit(x, y, z):
    n = math.sqrt(x * x + y * y + z * z)
    return [x / n, y / n, z / n]


PAIRS = [
    (unit(0.3, -0.2, 0.9), unit(-0.25, 0.3, 0.85)),
    (unit(0.7, 0.1, 0.3), unit(-0.6, -0.2, 0.5)),
    (unit(0.1, 0.4, 0.8), unit(-0.2, -0.5, -0.7)),
    (unit(-0.3, 0.2, -0.9), unit(0.35, -0.1, 0.8)),
    (unit(0.2, 0.1, 0.95), unit(0.1, 0.05, 0.99)),
]

for name, props in MODELS.items():
    bsdf = mi.load_dict(props)
    ctx = mi.BSDFContext()
    for wo, wi in PAIRS:
        si = mi.SurfaceInteraction3f()
        si.n = [0, 0, 1]
        si.sh_frame = mi.Frame3f(si.n)
        si.wi = wo
        value, pdf = bsdf.eval_pdf(ctx, si, wi)
        c = abs(wi[2])
        f = [value[i] / c for i in range(3)]
        v = lambda w: "[" + ", ".join(repr(float(np.float32(x))) for x in w) + "]"
        print(f'("{name}", {v(wo)}, {v(wi)}, [{f[0]:.7e}, {f[1]:.7e}, {f[2]:.7e}], {pdf:.7e}),')
