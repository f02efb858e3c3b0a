#!/usr/bin/env bash
# `bench` on a processor without what the build targets (x86-64-v3, .cargo/config.toml) must
# stop with one line and exit status 2, not crash on an illegal instruction. Emulates a 2008
# processor (Nehalem: no AVX) and a 2011 one (Sandy Bridge: AVX without AVX2 or FMA) with
# qemu's user mode, installed when missing (apt-get, as root), and a 2013 one (Haswell) that
# must run. Usage: scripts/test_processor_check.sh [path/to/bench]
set -euo pipefail
bench=${1:-target/release/bench}
if [ "$(uname -m)" != x86_64 ] || ! grep -qw avx2 /proc/cpuinfo; then
    echo "not an x86-64-v3 build on this machine: nothing to check"
    exit 0
fi
if ! command -v qemu-x86_64 >/dev/null; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq qemu-user >/dev/null
fi
expected='error: this build needs a processor with AVX2, FMA and BMI2'
err=$(mktemp)
trap 'rm -f "$err"' EXIT
for cpu in Nehalem SandyBridge; do
    status=0
    qemu-x86_64 -cpu "$cpu" "$bench" run experiments/cornell.toml >/dev/null 2>"$err" || status=$?
    message=$(grep -v '^qemu-x86_64: warning' "$err" || true)
    lines=$(printf '%s\n' "$message" | grep -c . || true)
    if [ "$status" != 2 ] || [ "$lines" != 1 ] || [[ "$message" != "$expected"* ]]; then
        echo "FAIL $cpu: exit $status, stderr: $message"
        exit 1
    fi
    echo "PASS $cpu: exit 2, one line"
done
if ! qemu-x86_64 -cpu Haswell "$bench" --version 2>/dev/null | grep -q '^bench '; then
    echo "FAIL Haswell: bench does not run"
    exit 1
fi
echo "PASS Haswell: runs"
