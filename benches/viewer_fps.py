"""Frames per second of `tileraster view`, measured in the browser: Debian's chromium, headless,
driven by playwright, drags the camera without pause for a while over a mesh of about 100,000
triangles at 1280 × 720, and counts the frames the page showed (each a fresh frame of the engine,
drawn on the server, sent as RGBA and put on the canvas).

    python benches/viewer_fps.py [--binary target/release/tileraster] [--seconds 10] [--backend cpu]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from playwright.sync_api import sync_playwright

CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking", "--disable-component-update",
                 "--disable-sync"]


def terrain_obj(path: Path, n: int) -> int:
    """An n × n lattice of smooth terrain as an OBJ file: 2 (n − 1)² triangles."""
    xs, ys = np.meshgrid(np.linspace(0, 2000, n), np.linspace(0, 1200, n))
    z = 80 + 40 * np.sin(xs / 170) * np.cos(ys / 110) + 15 * np.sin(xs / 37 + ys / 53)
    with open(path, "w") as f:
        f.writelines(f"v {x:.3f} {y:.3f} {h:.3f}\n" for x, y, h in zip(xs.ravel(), ys.ravel(), z.ravel()))
        for j in range(n - 1):
            for i in range(n - 1):
                a, b, c, d = j * n + i + 1, j * n + i + 2, (j + 1) * n + i + 1, (j + 1) * n + i + 2
                f.write(f"f {a} {b} {c}\nf {b} {d} {c}\n")
    return 2 * (n - 1) ** 2


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--binary", default="target/release/tileraster")
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--backend", default="cpu")
    parser.add_argument("--shading", default="smooth")
    parser.add_argument("--msaa", default="1")
    parser.add_argument("--mesh", help="this mesh instead of the 100,000-triangle terrain")
    parser.add_argument("--size", type=int, nargs=2, default=[1280, 720])
    parser.add_argument("--camera", help="the viewer's starting --camera (default: its framing); "
                        "1000,600,900,1000,600,80,0,1,0 fills the frame with the terrain")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as d:
        mesh = Path(d) / "terrain.obj"
        triangles = terrain_obj(mesh, 225) if args.mesh is None else None
        mesh = Path(args.mesh) if args.mesh else mesh
        server = subprocess.Popen([args.binary, "view", str(mesh), "--port", "0", "--backend", args.backend, "--shading", args.shading, "--msaa", args.msaa,
                                   "--size", *map(str, args.size), *(["--camera", args.camera] if args.camera else [])],
                                  stderr=subprocess.PIPE, text=True)
        url = next(line for line in server.stderr if "http://" in line).split("tileraster view: ")[1].split()[0]
        try:
            with sync_playwright() as p:
                browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=CHROMIUM_ARGS)
                page = browser.new_page(viewport={"width": 1800, "height": 800})
                page.goto(url)
                page.wait_for_function("window.viewer.frames > 0 && window.viewer.idle", timeout=120_000)
                box = page.locator("#frame").bounding_box()
                x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
                page.mouse.move(x, y)
                page.mouse.down()
                first, start = page.evaluate("window.viewer.frames"), time.perf_counter()
                # The drag's moves come from the page itself, every 8 ms (a mouse reports at
                # 125 Hz or more): the camera changes faster than frames come, and no round trip
                # to this script paces them.
                page.evaluate("""([x, y, seconds]) => new Promise(done => {
                    const start = performance.now();
                    let k = 0;
                    const timer = setInterval(() => {
                        k += 1;
                        window.dispatchEvent(new MouseEvent("mousemove", { clientX: x + 200 * Math.sin(k / 40), clientY: y + 60 * Math.sin(k / 61) }));
                        if (performance.now() - start > seconds * 1000) { clearInterval(timer); done(); }
                    }, 8);
                })""", [x, y, args.seconds])
                frames, elapsed = page.evaluate("window.viewer.frames") - first, time.perf_counter() - start
                server_ms = page.evaluate("window.viewer.serverMs")[-frames:]
                page.mouse.up()
                command = page.text_content("#command")
                browser.close()
        finally:
            server.terminate()
            server.wait()
    print(json.dumps({"triangles": triangles, "size": args.size, "backend": args.backend, "shading": args.shading, "msaa": int(args.msaa),
                      "seconds": round(elapsed, 2), "frames": frames, "frames_per_second": round(frames / elapsed, 1), "camera": args.camera or "framing",
                      "server_frame_ms_median": round(statistics.median(server_ms), 1), "last_command": command}))


if __name__ == "__main__":
    sys.exit(main())
