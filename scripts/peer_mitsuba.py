#!/usr/bin/env python3
"""Throughput of the peer: Mitsuba 3's `path` integrator on `mi.cornell_box()`.

Same scene as `scenes/cornell-box.toml` (geometry, reflectances, light), 256x256, box pixel
filter, max_depth 5 (= our max_depth 4: Mitsuba counts segments), no Russian roulette (Mitsuba
starts it at depth 5). Prints samples/s and the thread count; run it right after `bench perf`
on the same machine and quote the ratio (see docs/design.md, "Performance").

    pip install mitsuba          # 3.x; variant scalar_rgb needs nothing else
    python3 scripts/peer_mitsuba.py --spp 64 --threads 2

The JIT variant needs an LLVM >= 17 (Debian 12: `apt-get install libllvm19`):

    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
        python3 scripts/peer_mitsuba.py --spp 64 --threads 2 --variant llvm_ad_rgb
"""
import argparse
import time

import drjit as dr
import mitsuba as mi


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--threads", type=int, default=0, help="0 = all cores")
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    mi.set_variant(args.variant)
    if args.threads > 0:
        dr.set_thread_count(args.threads)
    d = mi.cornell_box()
    d["sensor"]["film"]["rfilter"] = {"type": "box"}
    d["sensor"]["film"]["width"] = d["sensor"]["film"]["height"] = 256
    d["integrator"] = {"type": "path", "max_depth": 5}
    scene = mi.load_dict(d)
    mi.render(scene, spp=4)  # warm-up
    rates = []
    for _ in range(args.repeats):
        t = time.perf_counter()
        img = mi.render(scene, spp=args.spp)
        dr.eval(img)
        dr.sync_thread()
        rates.append(256 * 256 * args.spp / (time.perf_counter() - t))
    rates.sort()
    print(f"mitsuba {mi.__version__} {args.variant}: {rates[len(rates) // 2]:.0f} samples/s "
          f"(median of {args.repeats}, 256x256, spp {args.spp}, max_depth 5, threads {dr.thread_count()})")


if __name__ == "__main__":
    main()
