#!/usr/bin/env python3
"""Drives a run's index.html in a real headless Chromium and checks what it shows.

    python3 scripts/test_report_page.py [--bench target/release/bench]

Runs a small experiment (two strategies on two scenes, equal samples and equal time,
two seeds) into a temporary directory, opens its index.html from disk, and through the Chrome
DevTools Protocol (over a pipe: no network, no Python packages) presses keys, turns the mouse
wheel and reads back the canvases and the metrics panel. Every check compares with files the
run wrote by another code path: the PNG previews and error maps (Rust's tone mapping and colour
map) and metrics.csv. Chromium comes from the distribution's packages and is installed here
when missing (apt-get, as root). Exits 0 when every check passes.
"""

import argparse
import csv
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import time
import zlib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FAILURES = []


def check(ok, what):
    print(("PASS " if ok else "FAIL ") + what, flush=True)
    if not ok:
        FAILURES.append(what)


def ensure_chromium():
    for name in ["chromium", "chromium-browser"]:
        path = shutil.which(name)
        if path:
            return path
    if os.geteuid() != 0:
        sys.exit("chromium is not installed and this is not root: apt-get install chromium")
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    subprocess.run(["apt-get", "update", "-qq"], check=True, env=env)
    subprocess.run(["apt-get", "install", "-y", "-qq", "chromium"], check=True, env=env,
                   stdout=subprocess.DEVNULL)
    return shutil.which("chromium")


def read_png(path):
    """8-bit RGB or RGBA, non-interlaced PNG as rows of (r, g, b) (what the run writes)."""
    data = Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", path
    pos, idat, width = 8, b"", 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and colour in (2, 6) and interlace == 0, (path, depth, colour)
            channels = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = zlib.decompress(idat)
    stride = width * channels
    rows, prev = [], bytearray(stride)
    for y in range(height):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b = prev[i]
            c = prev[i - channels] if i >= channels else 0
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append([tuple(line[x * channels:x * channels + 3]) for x in range(width)])
        prev = line
    return rows


class Browser:
    """Chromium with the DevTools protocol on file descriptors 3 (in) and 4 (out)."""

    def __init__(self, chromium, width, height):
        to_chrome_r, self.to_chrome = os.pipe()
        self.from_chrome, from_chrome_w = os.pipe()

        def fds():
            # Through high numbers first, so that neither end clobbers the other on its way to 3
            # and 4; close_fds then keeps 3 and 4, which pass_fds names.
            high_in, high_out = os.dup2(to_chrome_r, 100), os.dup2(from_chrome_w, 101)
            os.dup2(high_in, 3)
            os.dup2(high_out, 4)

        self.profile = tempfile.mkdtemp(prefix="chromium-profile-")
        self.proc = subprocess.Popen(
            [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             "--remote-debugging-pipe", f"--user-data-dir={self.profile}", f"--window-size={width},{height}",
             "about:blank"],
            preexec_fn=fds, pass_fds=(3, 4), stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL)
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        self.buffer, self.next_id, self.events, self.session = b"", 0, [], None

    def send(self, method, params=None, session=True):
        self.next_id += 1
        msg = {"id": self.next_id, "method": method, "params": params or {}}
        if session and self.session:
            msg["sessionId"] = self.session
        os.write(self.to_chrome, json.dumps(msg).encode() + b"\0")
        deadline = time.time() + 60
        while time.time() < deadline:
            while b"\0" not in self.buffer:
                chunk = os.read(self.from_chrome, 1 << 16)
                if not chunk:
                    raise RuntimeError("chromium closed the pipe")
                self.buffer += chunk
            raw, self.buffer = self.buffer.split(b"\0", 1)
            reply = json.loads(raw)
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply.get("result", {})
            self.events.append(reply)
        raise RuntimeError(f"{method}: no answer")

    def open(self, url):
        target = self.send("Target.createTarget", {"url": "about:blank"}, session=False)["targetId"]
        self.session = self.send("Target.attachToTarget", {"targetId": target, "flatten": True},
                                 session=False)["sessionId"]
        for domain in ["Page", "Runtime", "Network", "Log"]:
            self.send(f"{domain}.enable")
        self.send("Page.navigate", {"url": url})
        for _ in range(200):
            if self.eval("document.readyState") == "complete" and self.eval("!!window.viewer"):
                return
            time.sleep(0.05)
        raise RuntimeError("the page did not load its viewer")

    def eval(self, expression):
        r = self.send("Runtime.evaluate", {"expression": expression, "returnByValue": True})
        if "exceptionDetails" in r:
            raise RuntimeError(f"{expression}: {r['exceptionDetails']}")
        return r["result"].get("value")

    def key(self, key, code=None, vk=0):
        for kind in ["keyDown", "keyUp"]:
            params = {"type": kind, "key": key, "code": code or key, "windowsVirtualKeyCode": vk}
            if kind == "keyDown" and len(key) == 1:
                params["text"] = key
            self.send("Input.dispatchKeyEvent", params)

    def wheel(self, x, y, delta_y):
        self.send("Input.dispatchMouseEvent", {"type": "mouseWheel", "x": x, "y": y, "deltaX": 0,
                                               "deltaY": delta_y})

    def close(self):
        self.proc.kill()
        self.proc.wait()
        shutil.rmtree(self.profile, ignore_errors=True)


def run_experiment(bench, work):
    exp = work / "page.toml"
    exp.write_text(f"""name = "page"
scenes = ["{ROOT / 'scenes/ci-tiny.toml'}", "{ROOT / 'scenes/cornell-empty.toml'}"]
references = "{ROOT / 'references'}"
output = "{work / 'results'}"
spp = [1, 4]
seconds = [0.2]
seeds = 2

[[strategy]]
kind = "path"

[[strategy]]
kind = "path"
label = "path-uniform"
bsdf_sampling = "uniform"
""")
    out = subprocess.run([bench, "--threads", "2", "run", str(exp)], check=True, capture_output=True, text=True)
    return Path(out.stdout.strip().splitlines()[-1])


SHOWN = "JSON.stringify(document.getElementById('status').dataset)"


def state(b):
    return json.loads(b.eval(SHOWN))


def shown_file(b):
    """The run-relative EXR of the image shown, from the metrics panel."""
    return b.eval("[...document.querySelectorAll('#metrics tr')].find(r => r.cells[0] && "
                  "r.cells[0].textContent === 'file').cells[1].textContent")


def sample_points(b, canvas):
    """A 5 × 5 grid of canvas points with the image pixel under each, where there is one."""
    w, h = b.eval(f"[viewer.views[{canvas}].width, viewer.views[{canvas}].height]")
    pts = []
    for i in range(5):
        for j in range(5):
            x, y = (i + 0.5) * w / 5, (j + 0.5) * h / 5
            p = b.eval(f"viewer.imagePixelAt({x}, {y}, viewer.views[{canvas}])")
            if p:
                # The centre of that pixel on the canvas, away from its edges.
                cx, cy = b.eval(f"viewer.canvasPointOf({p[0]}, {p[1]}, viewer.views[{canvas}])")
                pts.append((int(cx), int(cy), p[0], p[1]))
    return pts


def canvas_rgb(b, canvas, x, y):
    return tuple(b.eval(f"Array.from(viewer.views[{canvas}].getContext('2d').getImageData({x}, {y}, 1, 1).data.slice(0, 3))"))


def compare_canvas_with_png(b, canvas, png_rows, tolerance):
    worst = 0
    for x, y, ix, iy in sample_points(b, canvas):
        got, want = canvas_rgb(b, canvas, x, y), png_rows[iy][ix]
        worst = max(worst, max(abs(g - w) for g, w in zip(got, want)))
    return worst <= tolerance, worst


def srgb_decode(v):
    v /= 255
    return v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4


def srgb8(linear):
    v = min(max(linear, 0.0), 1.0)
    enc = 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055
    return int(enc * 255 + 0.5)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--bench", default=str(ROOT / "target/release/bench"))
    args = parser.parse_args()
    chromium = ensure_chromium()
    work = Path(tempfile.mkdtemp(prefix="page-test-"))
    try:
        run = run_experiment(args.bench, work)
        rows = list(csv.DictReader(open(run / "metrics.csv")))
        strategies = list(dict.fromkeys(r["strategy"] for r in rows))

        b = Browser(chromium, 1366, 768)
        try:
            b.open((run / "index.html").as_uri())
            errors = [e for e in b.events if e.get("method") in ("Runtime.exceptionThrown",)]
            check(not errors, f"the page loads without script errors {errors[:1]}")
            urls = [e["params"]["request"]["url"] for e in b.events if e.get("method") == "Network.requestWillBeSent"]
            check(all(u.startswith(("file:", "data:")) for u in urls), f"nothing is loaded from a network: {urls}")

            s = state(b)
            check(s["scene"] == "ci-tiny" and s["image"] == strategies[0] and s["budget"] == "4 spp",
                  f"first view: scene, first strategy, largest spp checkpoint ({s})")
            ok, worst = compare_canvas_with_png(b, 0, read_png(run / Path(shown_file(b)).with_suffix(".png")), 1)
            check(ok, f"the image shown is the run's preview of {s['image']} (largest difference {worst}/255)")
            err_png = read_png(run / (str(Path(shown_file(b)).with_suffix("")) + "_error.png"))
            ok, worst = compare_canvas_with_png(b, 1, err_png, 4)
            check(ok, f"the error view is the run's error map (largest difference {worst}/255)")

            b.key("2", "Digit2", 50)
            s = state(b)
            check(s["image"] == strategies[1], f"key 2 shows the second strategy ({s['image']})")
            ok, worst = compare_canvas_with_png(b, 0, read_png(run / Path(shown_file(b)).with_suffix(".png")), 1)
            check(ok, f"… and the canvas shows its preview (largest difference {worst}/255)")
            mse_cell = b.eval("[...document.querySelectorAll('#metrics tr')].find(r => r.cells[0] && "
                              "r.cells[0].textContent === 'MSE, this seed').cells[1].textContent")
            row = min((r for r in rows if r["strategy"] == strategies[1] and r["budget"] == "spp"
                       and float(r["budget_value"]) == 4.0), key=lambda r: int(r["seed"]))
            check(abs(float(mse_cell) / float(row["mse"]) - 1) < 1e-3,
                  f"the metrics beside it are its row's (MSE {mse_cell} vs {row['mse']})")

            b.key("r", "KeyR", 82)
            s = state(b)
            check(s["image"].startswith("reference"), f"key r shows the reference ({s['image']})")
            ok, worst = compare_canvas_with_png(b, 0, read_png(run / "references/ci-tiny.png"), 1)
            check(ok, f"… as the reference's own preview (largest difference {worst}/255)")
            b.key("ArrowRight", "ArrowRight", 39)
            check(state(b)["image"] == strategies[0], "→ after the reference wraps to the first image")
            b.key("ArrowLeft", "ArrowLeft", 37)
            b.key("ArrowLeft", "ArrowLeft", 37)
            check(state(b)["image"] == strategies[-1], "← steps back past the reference to the last strategy")
            b.key("b", "KeyB", 66)
            s = state(b)
            check(s["budget"] == "0.2 s" and s["image"] == strategies[-1], f"key b switches to the time budget ({s})")
            ok, worst = compare_canvas_with_png(b, 0, read_png(run / Path(shown_file(b)).with_suffix(".png")), 1)
            check(ok and "_t0.2s" in shown_file(b), f"… showing the equal-time image ({shown_file(b)}, {worst}/255)")

            before = [(x, y, canvas_rgb(b, 0, x, y)) for x, y, _, _ in sample_points(b, 0)]
            b.key("+", "Equal", 187)
            b.key("+", "Equal", 187)
            s = state(b)
            worst = 0
            for x, y, rgb in before:
                now = canvas_rgb(b, 0, x, y)
                for c in range(3):
                    if rgb[c] < 200:
                        worst = max(worst, abs(now[c] - srgb8(2 * srgb_decode(rgb[c]))))
            check(float(s["exposure"]) == 1.0 and worst <= 4,
                  f"+ + raises the exposure by one stop: twice the linear value (largest difference {worst}/255)")
            b.key("0", "Digit0", 48)
            check(float(state(b)["exposure"]) == 0.0, "0 resets the exposure")

            def under(canvas, fx, fy):
                """The image pixel under the point at fractions (fx, fy) of a view."""
                return b.eval(f"(c => viewer.imagePixelAt(c.width * {fx}, c.height * {fy}, c))(viewer.views[{canvas}])")

            rect = b.eval("(r => [r.left, r.top, r.width, r.height])(viewer.views[0].getBoundingClientRect())")
            fx, fy = 0.37, 0.41
            before = under(0, fx, fy)
            b.wheel(rect[0] + fx * rect[2], rect[1] + fy * rect[3], -100)
            b.wheel(rect[0] + fx * rect[2], rect[1] + fy * rect[3], -100)
            s = state(b)
            in_image, in_error = under(0, fx, fy), under(1, fx, fy)
            corner_image, corner_error = under(0, 0.05, 0.05), under(1, 0.05, 0.05)
            check(float(s["zoom"]) > 1.5 and before == in_image == in_error and corner_image == corner_error,
                  f"the wheel zooms about the cursor, both views in step (zoom {s['zoom']}, {before} {in_image} "
                  f"{in_error}, corners {corner_image} {corner_error})")
            ok, worst = compare_canvas_with_png(b, 1, read_png(run / (str(Path(shown_file(b)).with_suffix("")) + "_error.png")), 4)
            check(ok, f"the zoomed error view still matches the error map (largest difference {worst}/255)")

            b.key("ArrowDown", "ArrowDown", 40)
            s = state(b)
            ok, worst = compare_canvas_with_png(b, 0, read_png(run / Path(shown_file(b)).with_suffix(".png")), 1)
            check(s["scene"] == "cornell-empty" and float(s["zoom"]) == 1.0 and "cornell-empty_" in shown_file(b) and ok,
                  f"↓ shows the next scene, fitted, with its own image ({s}, {worst}/255)")
            b.key("ArrowUp", "ArrowUp", 38)
            check(state(b)["scene"] == "ci-tiny", "↑ goes back")

            scroll = b.eval("[document.documentElement.scrollWidth, window.innerWidth]")
            viewer_rect = b.eval("(r => [r.right, r.height])(document.getElementById('viewer').getBoundingClientRect())")
            check(scroll[0] <= scroll[1] and viewer_rect[0] <= 1366 and viewer_rect[1] <= 768,
                  f"fits a 1366 × 768 laptop screen (page width {scroll}, viewer right/height {viewer_rect})")
        finally:
            b.close()
    finally:
        shutil.rmtree(work, ignore_errors=True)
    if FAILURES:
        sys.exit(f"{len(FAILURES)} check(s) failed")
    print("all page checks passed")


if __name__ == "__main__":
    main()
