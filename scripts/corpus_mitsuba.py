#!/usr/bin/env python3
"""Cross-check our `path` (or another unbiased strategy: --strategy, --set, as in
crosscheck_mitsuba.py) against Mitsuba 3 on every Mitsuba 3 scene of a directory.

    cargo build --release
    python3 -m pip install mitsuba==3.9.1 numpy
    python3 scripts/corpus_mitsuba.py scenes/mitsuba                 # the shipped corpus (CI)
    python3 scripts/corpus_mitsuba.py DIR --report corpus.md         # any directory of scenes
    python3 scripts/corpus_mitsuba.py mitsuba-data/docs/scenes --merge mitsuba-data/common

For each `*.xml` directly in DIR (files that are not a `<scene>` are skipped; included files
usually live in a subdirectory): our importer either refuses the scene — reported with its
one-line reason — or loads it, and then both renderers render it at equal samples, K seeds
each, and `crosscheck_mitsuba.judge` applies the per-pixel Welch test against the rate of
false positives chance allows (and the z-test of the image means). The report lists every
scene as passed, FAILED, refused by us (with the reason) or refused by Mitsuba, and the
totals; the exit status is 1 if a loaded scene failed.

To make runs affordable and the two renders comparable, the scene directory is copied to a
temporary directory and every `.xml` file there is edited the same way for both renderers:
each film is resized so that its longer side is --size pixels (aspect kept), and every film
gets a `box` pixel filter on both sides (the report says where that changed the scene), or
the one --rfilter names (`keep`: each scene's own, with the ones we lack made `box`).
Integrator settings are Mitsuba `path` with our max_depth + 1 and no Russian roulette on
either side, as in crosscheck_mitsuba.py; our next-event estimation picks lights uniformly and
samples spheres by their cone (`--light-selection uniform --sphere-light-sampling cone`) as
Mitsuba does, so that both estimators have the same noise: the per-pixel Welch test assumes
means of similar distributions, and a firefly-prone estimator against a smooth one fails it by
skewness alone (measured on Veach's scene with our default power selection).

The whole corpus of Mitsuba's own documentation scenes (BSD-3-Clause, with Mitsuba 3):
    git clone --depth 1 https://github.com/mitsuba-renderer/mitsuba-data
    python3 scripts/corpus_mitsuba.py mitsuba-data/docs/scenes --report corpus.md
"""
import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from crosscheck_mitsuba import has_media, judge, render_mitsuba, render_ours  # noqa: E402


def resize_films(text, longest, rfilter="keep"):
    """Every <film> block scaled so that its longer side is `longest` (Mitsuba's default film is
    768 x 576); returns the new text and whether an rfilter photon-bench lacks (one with negative
    lobes: lanczos, mitchell, catmullrom) was replaced by a box."""
    replaced = False
    defaults = dict(re.findall(r'<default\s+name="(\w+)"\s+value="([^"]*)"', text))

    def one_film(m):
        nonlocal replaced
        # A film size given as a parameter ($width) becomes its default value.
        block = re.sub(r'value="\$(\w+)"', lambda v: f'value="{defaults.get(v.group(1), v.group(0)[7:-1])}"', m.group(0))
        w = re.search(r'<integer\s+name="width"\s+value="(\d+)"\s*/>', block)
        h = re.search(r'<integer\s+name="height"\s+value="(\d+)"\s*/>', block)
        width, height = (int(w.group(1)) if w else 768), (int(h.group(1)) if h else 576)
        scale = longest / max(width, height)
        nw, nh = max(1, round(width * scale)), max(1, round(height * scale))
        block = re.sub(r'(<integer\s+name="width"\s+value=")\d+(")', rf"\g<1>{nw}\2", block)
        block = re.sub(r'(<integer\s+name="height"\s+value=")\d+(")', rf"\g<1>{nh}\2", block)
        tag_end = block.index(">") + 1
        # A crop window shrinks with its film and stays on it: each given offset is scaled and
        # kept inside the film, each given size scaled and kept between 1 and what is left.
        for axis, side in (("x", nw), ("y", nh)):
            size_key = "crop_width" if axis == "x" else "crop_height"
            pattern = lambda key: r'(<integer\s+name="' + key + r'"\s+value=")(\d+)(")'  # noqa: E731
            offset = 0
            m_off = re.search(pattern(f"crop_offset_{axis}"), block)
            if m_off:
                offset = min(round(int(m_off.group(2)) * scale), side - 1)
                block = re.sub(pattern(f"crop_offset_{axis}"), rf"\g<1>{offset}\3", block, count=1)
            m_size = re.search(pattern(size_key), block)
            if m_size:
                size = max(1, min(round(int(m_size.group(2)) * scale), side - offset))
                block = re.sub(pattern(size_key), rf"\g<1>{size}\3", block, count=1)
        if not w:
            block = block[:tag_end] + f'<integer name="width" value="{nw}"/>' + block[tag_end:]
        if not h:
            block = block[:tag_end] + f'<integer name="height" value="{nh}"/>' + block[tag_end:]
        if rfilter == "keep":
            kept = r'(?!(?:box|tent|gaussian)")'
            new = re.sub(r'<rfilter\s+type="' + kept + r'[^"]*"\s*/>', '<rfilter type="box"/>', block)
            new = re.sub(r'<rfilter\s+type="' + kept + r'[^"]*"\s*>.*?</rfilter>', '<rfilter type="box"/>', new, flags=re.S)
            replaced |= new != block
            return new
        # Every film gets the same filter (a film without one gets it too).
        new = re.sub(r'<rfilter\b[^>]*/>', "", block)
        new = re.sub(r'<rfilter\b.*?</rfilter>', "", new, flags=re.S)
        new = new[: new.index(">") + 1] + f'<rfilter type="{rfilter}"/>' + new[new.index(">") + 1 :]
        replaced |= True
        return new

    text = re.sub(r"<film\b.*?</film>", one_film, text, flags=re.S)
    return text, replaced


def prepare(src, dst, longest, rfilter="keep"):
    """Copies the scene directory (and its parent, for relative <path>s reaching outside it) and
    edits every XML file; returns the directory in the copy that mirrors `src` and the set of
    files whose filter was replaced."""
    src = os.path.abspath(src)
    shutil.copytree(src, dst, dirs_exist_ok=True)
    replaced = set()
    for root, _, files in os.walk(dst):
        for name in files:
            if name.endswith(".xml"):
                path = os.path.join(root, name)
                with open(path, encoding="utf-8", errors="replace") as f:
                    text = f.read()
                new, filt = resize_films(text, longest, rfilter)
                if filt:
                    replaced.add(os.path.relpath(path, dst))
                if new != text:
                    with open(path, "w", encoding="utf-8") as f:
                        f.write(new)
    return replaced


def levels_reached(src):
    """How many directories above `src` the `<path value="../…"/>` of its XML files reach."""
    most = 0
    for root, _, files in os.walk(src):
        depth = os.path.relpath(root, src).count(os.sep) + (root != src)
        for name in files:
            if name.endswith(".xml"):
                with open(os.path.join(root, name), encoding="utf-8", errors="replace") as f:
                    for value in re.findall(r'<path\s+value="([^"]*)"', f.read()):
                        ups = len(re.findall(r"\.\.(?:/|$)", value))
                        most = max(most, ups - depth)
    return most


def is_scene(path):
    with open(path, encoding="utf-8", errors="replace") as f:
        head = f.read(4096)
    head = re.sub(r"<!--.*?-->", "", head, flags=re.S)
    head = re.sub(r"<\?.*?\?>", "", head, flags=re.S)
    return re.match(r"\s*<scene\b", head) is not None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dir", help="a directory of Mitsuba 3 scenes")
    ap.add_argument("--size", type=int, default=48, help="longer film side after resizing")
    ap.add_argument("--spp", type=int, default=16, help="samples per pixel of each seed's image")
    ap.add_argument("--seeds", type=int, default=16, help="independent images per renderer (K)")
    ap.add_argument("--max-depth", type=int, default=8, help="our max_depth (scattering events)")
    ap.add_argument("--only", nargs="*", help="scene file names to run (default: all)")
    ap.add_argument("--exclude", nargs="*", default=[], help="scene file names to leave out")
    ap.add_argument("--report", help="also write the table as Markdown to this file")
    ap.add_argument("--bench", default="target/release/bench")
    ap.add_argument("--strategy", default="path", help="our strategy (an unbiased one; default path)")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", help="a parameter of --strategy")
    ap.add_argument(
        "--rfilter",
        choices=["box", "keep", "tent", "gaussian"],
        default="box",
        help="every film's pixel filter on both sides (default box; keep: as each scene says). "
        "Next to a small bright light or a light's edge a filtered pixel's per-seed means are "
        "skewed differently on the two sides at 64 spp (Mitsuba spreads each hit over its "
        "neighbours, we sample pixels by the filter): same mean, but the per-pixel test fails "
        "(8 of 56 documentation scenes with keep, all of them pass with box)",
    )
    ap.add_argument(
        "--merge",
        action="append",
        default=[],
        help="a directory whose contents are copied into the scene directory's copy (repeatable): "
        "Mitsuba's documentation scenes find their meshes and textures in mitsuba-data/common",
    )
    args = ap.parse_args()
    bench = os.path.abspath(args.bench)

    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    rows = []
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        # Copy as many parent directories as a <path value="../…"/> reaches, so that it still
        # resolves in the copy.
        src = os.path.abspath(args.dir)
        top = src
        for _ in range(levels_reached(src)):
            top = os.path.dirname(top)
        base = os.path.join(tmp, "copy")
        replaced = prepare(top, base, args.size, args.rfilter)
        copied_dir = os.path.join(base, os.path.relpath(src, top))
        for extra in args.merge:
            shutil.copytree(os.path.abspath(extra), copied_dir, dirs_exist_ok=True)
        names = sorted(f for f in os.listdir(copied_dir) if f.endswith(".xml"))
        if args.only:
            names = [n for n in names if n in args.only]
        names = [n for n in names if n not in args.exclude]
        for name in names:
            path = os.path.join(copied_dir, name)
            if not is_scene(path):
                continue
            row = {"scene": name, "filter": any(r.endswith(name) for r in replaced)}
            out = os.path.join(tmp, "ours")
            # Our importer and the strategy each refuse what they do not handle, before rendering.
            probe = subprocess.run(
                [bench, "reference", path, "--spp", "1", "--out", out, "--force"]
                if args.strategy == "path"
                else [bench, "render", path, "--strategy", args.strategy, "--spp", "1", "--out",
                      os.path.join(out, "probe.exr"), "--force", *[a for v in args.set for a in ("--set", v)]],
                capture_output=True,
                text=True,
            )
            if probe.returncode != 0:
                reason = (probe.stderr.strip().splitlines() or ["(no message)"])[-1]
                row.update(status="refused", reason=reason.replace(tmp, "…"))
                rows.append(row)
                print(f"{name}: refused: {row['reason']}", flush=True)
                continue
            try:
                try:
                    scene = mi.load_file(path)
                except Exception as e:  # noqa: BLE001
                    # A sample count `$spp` without a <default> (some documentation scenes):
                    # any value does, the render call sets the samples.
                    if "undefined parameter: $spp" not in str(e):
                        raise
                    scene = mi.load_file(path, spp=str(args.spp))
            except Exception as e:  # noqa: BLE001 (any Mitsuba failure is a row of the report)
                row.update(status="mitsuba refused", reason=str(e).strip().splitlines()[-1][:200])
                rows.append(row)
                print(f"{name}: Mitsuba refused: {row['reason']}", flush=True)
                continue
            t0 = time.perf_counter()
            theirs = render_mitsuba(scene, args.spp, args.seeds, args.max_depth,
                                    "volpath" if has_media(path) else "path")
            t_mitsuba = time.perf_counter() - t0
            t0 = time.perf_counter()
            ours = render_ours(bench, path, args.spp, args.seeds, args.max_depth, tmp,
                               ["--light-selection", "uniform", "--sphere-light-sampling", "cone"],
                               strategy=args.strategy, sets=args.set)
            t_ours = time.perf_counter() - t0
            h, w = ours.shape[1:3]
            print(f"{name}: {w}x{h}, {args.seeds} seeds x {args.spp} spp; Mitsuba {t_mitsuba:.1f} s, ours {t_ours:.1f} s")
            ok, summary = judge(ours, theirs, f"{name}: ours vs Mitsuba")
            row.update(status="passed" if ok else "FAILED", summary=summary, size=f"{w}x{h}")
            rows.append(row)
    counts = {s: sum(r["status"] == s for r in rows) for s in ("passed", "FAILED", "refused", "mitsuba refused")}
    loaded = counts["passed"] + counts["FAILED"]
    lines = [
        f"# Mitsuba 3 corpus: {args.dir}, our `{args.strategy}` {' '.join(args.set)}",
        "",
        f"{len(rows)} scenes: **{loaded} loaded, {counts['passed']} passed, {counts['FAILED']} failed, "
        f"{counts['refused']} refused by photon-bench**, {counts['mitsuba refused']} refused by Mitsuba "
        f"{mi.__version__}. Longer side {args.size} px, {args.seeds} seeds x {args.spp} spp per renderer, "
        f"our max_depth {args.max_depth}; {time.perf_counter() - started:.0f} s.",
        "",
        "| scene | result | mean ours/Mitsuba - 1 (z) | p < 0.05 | p < 0.001 | note |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        if "summary" in r:
            s = r["summary"]
            note = "pixel filter made box on both sides" if r["filter"] else ""
            lines.append(
                f"| {r['scene']} | {r['status']} | {100 * s['mean_rel']:+.2f} % ({s['z']:+.1f}) | {s['levels'][0.05][0]:.3f} | "
                f"{s['levels'][0.001][0]:.4f} | {note} |"
            )
        else:
            lines.append(f"| {r['scene']} | {r['status']} | | | | {r['reason'].replace('|', '/')} |")
    text = "\n".join(lines) + "\n"
    print()
    print(text)
    if args.report:
        with open(args.report, "w") as f:
            f.write(text)
    sys.exit(1 if counts["FAILED"] else 0)


if __name__ == "__main__":
    main()
