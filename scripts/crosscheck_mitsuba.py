#!/usr/bin/env python3
"""Cross-check our `path` (or any unbiased strategy) against Mitsuba 3's `path` integrator on
the same scene.

    cargo build --release
    python3 -m pip install mitsuba==3.9.1
    python3 scripts/crosscheck_mitsuba.py scenes/cornell-spheres.toml --size 64 64 --spp 16 --seeds 16
    python3 scripts/crosscheck_mitsuba.py scenes/mitsuba/veach-mis.xml --strategy bdpt

With --strategy KIND (and --set NAME=VALUE for its parameters) our side is that strategy,
rendered by `bench render` with max_depth = --max-depth and rr_depth = --max-depth (no Russian
roulette); it must be unbiased (`path`, `bdpt`, `light`, `vcm` with mode = "bpt", `ppg`,
`photon_guided`): the test compares means, and a consistent estimator's bias would fail it.
`light` leaves out paths whose last bounce before the eye is specular (module doc of
src/strategy/light.rs), so it passes only on scenes without mirrors or glass seen directly.

Steps: `bench export-mitsuba` writes the scene as Mitsuba 3 XML (resized with --size); Mitsuba
3.9.1 (`scalar_rgb`, box filter) and our `path` (`bench reference`, which renders the same XML
file, tests/mitsuba.rs proving it equal to the TOML scene) each render it with K independent
seeds at S spp. Conventions matched: Mitsuba's max_depth counts segments, ours scattering
events, so Mitsuba gets --max-depth + 1; Russian roulette is off on both sides (Mitsuba
rr_depth above its max_depth, ours rr_depth = max_depth), so both estimate exactly the same
truncated sum and differ only by noise.

The checks (exit status 1 if one fails):
1. Mean luminance (Rec. 709) of all K images: the difference of the two means within 4 of its
   standard errors, estimated from the K per-seed image means of each side (|z| < 4). Until
   2026-11-25 this was |ours / Mitsuba - 1| < 1 %, which is no test at all where a few very
   bright pixels (a small light seen directly, as in Veach's scene) make the image mean noisier
   than 1 %, and a weak one where the image mean is far more precise than that.
2. Per pixel, Welch's t on the K per-seed luminances of each side, its two-sided p-value from
   Student's t with the Welch-Satterthwaite degrees of freedom. If both renderers estimate the
   same image, the pixels' p-values are uniform: the fraction below 0.05, 0.01 and 0.001 must
   match that level to within 4 binomial standard deviations plus 20 % of the level (the t
   approximation is not exact for the skewed per-seed values of a caustic pixel). Only too
   many small p-values fail: with heavy-tailed pixels (a caustic through glass found by
   BSDF sampling is a rare large sample) Welch's t is conservative, so fewer pixels than
   chance predicts come out significant (measured on cornell-spheres: 2.7 % below 0.05), and
   the Kolmogorov-Smirnov distance of the p-values from uniform (reported, not judged) shows
   that excess of large p-values. Pixels that are
   constant on both sides and equal (black background, a light seen directly; equal to a relative
   10^-5, float rounding of the same radiance) are left out; constant but different pixels count
   as p = 0.
3. Negative controls, which the checks above must fail (so that they can fail): Mitsuba's
   images brightened by 3 %, and mirrored left-right.
"""
import argparse
import math
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np


def luminance(img):
    return 0.2126 * img[..., 0] + 0.7152 * img[..., 1] + 0.0722 * img[..., 2]


def _betacf(a, b, x, iterations=400):
    """Continued fraction of the incomplete beta function (modified Lentz), element-wise."""
    tiny = 1e-300
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c = np.ones_like(x)
    d = 1.0 - qab * x / qap
    d = np.where(np.abs(d) < tiny, tiny, d)
    d = 1.0 / d
    h = d.copy()
    np.seterr(over="ignore", invalid="ignore", divide="ignore")
    for m in range(1, iterations + 1):
        m2 = 2 * m
        aa = m * (b - m) * x / ((qam + m2) * (a + m2))
        d = 1.0 + aa * d
        d = np.where(np.abs(d) < tiny, tiny, d)
        c = 1.0 + aa / c
        c = np.where(np.abs(c) < tiny, tiny, c)
        d = 1.0 / d
        h *= d * c
        aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))
        d = 1.0 + aa * d
        d = np.where(np.abs(d) < tiny, tiny, d)
        c = 1.0 + aa / c
        c = np.where(np.abs(c) < tiny, tiny, c)
        d = 1.0 / d
        delta = d * c
        h *= delta
        if np.all(np.abs(delta - 1.0) < 1e-14):
            break
    return h


def betainc(a, b, x):
    """Regularized incomplete beta I_x(a, b), element-wise over arrays."""
    a, b, x = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float), np.asarray(x, float))
    lg = np.vectorize(math.lgamma)
    xc = np.clip(x, 1e-300, 1 - 1e-16)
    front = np.exp(lg(a + b) - lg(a) - lg(b) + a * np.log(xc) + b * np.log1p(-xc))
    direct = x < (a + 1.0) / (a + b + 2.0)
    out = np.where(direct, front * _betacf(a, b, xc) / a, 1.0 - front * _betacf(b, a, 1.0 - xc) / b)
    return np.where(x <= 0, 0.0, np.where(x >= 1, 1.0, out))


def t_two_sided_p(t, nu):
    """P(|T| >= |t|) for Student's t with nu degrees of freedom: I_{nu/(nu+t^2)}(nu/2, 1/2)."""
    t = np.asarray(t, float)
    return betainc(nu / 2.0, 0.5, nu / (nu + t * t))


def welch_p(a, b):
    """Per-pixel two-sided Welch p-values of stacks a, b (K, H, W); NaN where both are constant and equal."""
    k_a, k_b = a.shape[0], b.shape[0]
    va, vb = a.var(axis=0, ddof=1) / k_a, b.var(axis=0, ddof=1) / k_b
    diff = b.mean(axis=0) - a.mean(axis=0)
    se2 = va + vb
    # Numerically constant: the spread is float rounding of one value (a light seen directly,
    # summed in float32), not noise.
    scale = np.maximum(np.abs(a.mean(axis=0)), 1e-30)
    constant = np.sqrt(se2) <= 1e-6 * scale
    safe = np.where(constant, 1.0, se2)
    t = diff / np.sqrt(safe)
    nu = safe**2 / np.maximum(va**2 / (k_a - 1) + vb**2 / (k_b - 1), 1e-300)
    # Beyond 10^6 degrees of freedom Student's t is the normal distribution to 6 digits.
    p = t_two_sided_p(t, np.clip(nu, 1.0, 1e6))
    # Constant on both sides: equal up to float rounding of the same value (a light's radiance
    # read as float32 by one renderer and as float64 by the other) is no evidence either way.
    same = np.abs(diff) <= 1e-5 * scale
    p = np.where(constant, np.where(same, np.nan, 0.0), p)
    return p


def judge(ours, theirs, label):
    """Runs checks 1 and 2; returns (passed, summary dict)."""
    ya, yb = luminance(theirs), luminance(ours)
    mean_rel = yb.mean() / ya.mean() - 1.0
    per_seed_a, per_seed_b = ya.mean(axis=(1, 2)), yb.mean(axis=(1, 2))
    se = math.sqrt(per_seed_a.var(ddof=1) / len(per_seed_a) + per_seed_b.var(ddof=1) / len(per_seed_b))
    z = (per_seed_b.mean() - per_seed_a.mean()) / se if se > 0 else (0.0 if mean_rel == 0 else math.inf)
    p = welch_p(ya, yb).ravel()
    p = p[~np.isnan(p)]
    n = p.size
    levels = {}
    ok = abs(z) < 4.0
    for level in (0.05, 0.01, 0.001):
        frac = float(np.mean(p < level))
        sd = math.sqrt(level * (1 - level) / n)
        tol = 4 * sd + 0.2 * level
        levels[level] = (frac, tol)
        ok = ok and frac - level <= tol
    ps = np.sort(p)
    ks = float(np.max(np.maximum(np.arange(1, n + 1) / n - ps, ps - np.arange(n) / n)))
    print(
        f"{label}: mean luminance ours/Mitsuba - 1 = {100 * mean_rel:+.3f} % "
        f"(z = {z:+.2f}, limit |z| < 4; standard error {100 * se / per_seed_a.mean():.3f} %); {n} pixels tested"
    )
    for level, (frac, tol) in levels.items():
        print(f"    fraction with p < {level:<5}: {frac:.4f} (chance: {level}, allowed up to {level + tol:.4f})")
    print(f"    KS distance of the p-values from uniform: {ks:.4f} (1.36/sqrt(n) = {1.36 / math.sqrt(n):.4f})")
    print(f"    -> {'PASS' if ok else 'FAIL'}")
    return ok, {"mean_rel": mean_rel, "z": z, "levels": levels, "ks": ks, "n": n}


def read_exr(path):
    import mitsuba as mi

    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


def render_mitsuba(scene, spp, seeds, max_depth, integrator="path"):
    """K images (seeds 1000 + k) of Mitsuba's `path` (or `volpath`, which scenes with media
    need: our `path` renders their media) with our max_depth + 1 and no roulette."""
    import mitsuba as mi

    integrator = mi.load_dict({"type": integrator, "max_depth": max_depth + 1, "rr_depth": max_depth + 2})
    return np.stack(
        [
            np.array(mi.render(scene, integrator=integrator, spp=spp, seed=1000 + k), dtype=np.float64)[..., :3]
            for k in range(seeds)
        ]
    )


def has_media(xml, depth=0):
    """Whether a Mitsuba scene file (or a file it includes) declares a <medium>."""
    text = open(xml, encoding="utf-8").read()
    if "<medium" in text:
        return True
    for name in re.findall(r'<include\s+filename="([^"$]+)"', text) if depth < 8 else []:
        included = os.path.join(os.path.dirname(xml), name)
        if os.path.isfile(included) and has_media(included, depth + 1):
            return True
    return False


def render_ours(bench, scene_file, spp, seeds, max_depth, tmp, extra=(), threads=(), strategy="path", sets=()):
    """K images (seeds 0 … K - 1) of our `path` via `bench reference`, no roulette; `extra` are
    more `bench reference` arguments (light selection), `threads` the global `--threads N`.
    Another `strategy` renders via `bench render` with max_depth = rr_depth = `max_depth` (no
    rr_depth for `mlt` and `mps`) and the NAME=VALUE parameters `sets` (`extra` is then not
    used)."""
    stem = os.path.splitext(os.path.basename(scene_file))[0]
    images = []
    for k in range(seeds):
        out = os.path.join(tmp, f"ours{k}")
        if strategy == "path":
            command = [bench, *threads, "reference", scene_file, "--spp", str(spp), "--seed", str(k), "--out", out,
                       "--force", "--max-depth", str(max_depth), "--rr-depth", str(max_depth), *extra]
            exr = os.path.join(out, f"{stem}.exr")
        else:
            exr = os.path.join(out, f"{stem}.exr")
            # The Metropolis strategies' chains have no Russian roulette to turn off.
            roulette = [] if strategy in ("mlt", "mps") else [f"rr_depth={max_depth}"]
            depth = [f"max_depth={max_depth}", *roulette]
            command = [bench, *threads, "render", scene_file, "--strategy", strategy, "--spp", str(spp), "--seed",
                       str(k), "--out", exr, "--force", *[a for v in [*depth, *sets] for a in ("--set", v)]]
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        images.append(read_exr(exr))
    return np.stack(images)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", help="a scene file (TOML or Mitsuba XML)")
    ap.add_argument("--spp", type=int, default=16, help="samples per pixel of each seed's image")
    ap.add_argument("--seeds", type=int, default=16, help="independent images per renderer (K)")
    ap.add_argument("--max-depth", type=int, default=8, help="our max_depth (scattering events)")
    ap.add_argument("--size", type=int, nargs=2, metavar=("W", "H"), help="render at this resolution")
    ap.add_argument("--bench", default="target/release/bench")
    ap.add_argument("--threads", type=int, default=0, help="0: all cores")
    ap.add_argument("--strategy", default="path", help="our strategy (an unbiased one; default path)")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="a parameter of --strategy")
    args = ap.parse_args()

    # The t distribution's tail must be right before any verdict rests on it.
    assert abs(t_two_sided_p(2.2281388519649385, 10) - 0.05) < 1e-6
    assert abs(t_two_sided_p(1.959963984540054, 1e9) - 0.05) < 1e-6

    import drjit as dr
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    if args.threads > 0:
        dr.set_thread_count(args.threads)
    threads = ["--threads", str(args.threads)] if args.threads > 0 else []
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        xml = os.path.join(tmp, "scene.xml")
        subprocess.run([args.bench, "export-mitsuba", args.scene, "-o", xml], check=True)
        if args.size:
            with open(xml) as f:
                text = f.read()
            text = re.sub(r'name="width" value="\d+"', f'name="width" value="{args.size[0]}"', text, count=1)
            text = re.sub(r'name="height" value="\d+"', f'name="height" value="{args.size[1]}"', text, count=1)
            with open(xml, "w") as f:
                f.write(text)
        t0 = time.perf_counter()
        theirs = render_mitsuba(mi.load_file(xml), args.spp, args.seeds, args.max_depth,
                                "volpath" if has_media(xml) else "path")
        t_mitsuba = time.perf_counter() - t0
        t0 = time.perf_counter()
        ours = render_ours(args.bench, xml, args.spp, args.seeds, args.max_depth, tmp, threads=threads,
                           strategy=args.strategy, sets=args.set)
        t_ours = time.perf_counter() - t0
    h, w = ours.shape[1:3]
    print(
        f"{args.scene}: our {args.strategy} {' '.join(args.set)}: {w}x{h}, {args.seeds} seeds x {args.spp} spp per "
        f"renderer, our max_depth {args.max_depth} "
        f"= Mitsuba {mi.__version__} max_depth {args.max_depth + 1}, no Russian roulette; "
        f"render time Mitsuba {t_mitsuba:.1f} s, ours {t_ours:.1f} s"
    )
    ok, _ = judge(ours, theirs, "ours vs Mitsuba")
    brighter, _ = judge(ours, theirs * 1.03, "control: Mitsuba x 1.03 (must FAIL)")
    mirrored, _ = judge(ours, theirs[:, :, ::-1, :], "control: Mitsuba mirrored (must FAIL)")
    controls_fail = not brighter and not mirrored
    if not controls_fail:
        print("a negative control passed: the test cannot tell these images apart", file=sys.stderr)
    print(f"total {time.perf_counter() - started:.1f} s")
    sys.exit(0 if ok and controls_fail else 1)


if __name__ == "__main__":
    main()
