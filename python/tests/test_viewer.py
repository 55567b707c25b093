"""`tileraster view` in a real browser (Debian's chromium, headless, driven by playwright): the
page loads, a drag changes the frame, the command line it shows gives the CRC it shows, each key
does what it says; and the server answers hostile requests with errors and goes on."""

from __future__ import annotations

import http.client
import json
import os
import shlex
import socket
import subprocess
import time
import zlib
from pathlib import Path

import pytest

from test_tileraster import binary, terrain, write_obj

CHROMIUM = "/usr/bin/chromium"
# As a sandboxed root process on a closed network needs it (no background connections).
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking", "--disable-component-update",
                 "--disable-sync"]


def browser_or_fail():
    """playwright and Debian's chromium, or a loud failure (a skip only when asked for)."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError as e:
        missing = f"playwright for Python is not installed ({e})"
    else:
        if Path(CHROMIUM).is_file():
            return sync_playwright
        missing = f"no browser at {CHROMIUM} (apt-get install chromium)"
    if os.environ.get("TILERASTER_SKIP_BROWSER") == "1":
        print(f"SKIPPED (TILERASTER_SKIP_BROWSER=1): the viewer was not tested in a browser: {missing}")
        return None
    pytest.fail(f"{missing}; .ci/setup installs both. To skip the browser tests deliberately, set TILERASTER_SKIP_BROWSER=1.")


class Server:
    """`tileraster view ARGS` on a free port of 127.0.0.1."""

    def __init__(self, *args):
        self.process = subprocess.Popen([str(binary()), "view", *map(str, args), "--port", "0"], stderr=subprocess.PIPE, text=True)
        deadline = time.time() + 60
        for line in self.process.stderr:
            if "http://" in line:
                self.url = line[line.index("http://"):].split()[0]
                break
            assert time.time() < deadline, "the viewer did not start"
        else:
            raise AssertionError(f"the viewer stopped: exit {self.process.wait()}")
        self.host, self.port = self.url[len("http://"):].rstrip("/").rsplit(":", 1)

    def request(self, method, path, body=None, headers=None):
        connection = http.client.HTTPConnection(self.host, int(self.port), timeout=60)
        connection.request(method, path, body=body, headers=headers or {})
        response = connection.getresponse()
        data = response.read()
        connection.close()
        return response.status, data

    def frame(self, **request):
        status, data = self.request("POST", "/frame", json.dumps(request), {"Content-Type": "application/json"})
        if status != 200:
            return status, data.decode(), None
        length = int.from_bytes(data[:4], "little")
        reply = json.loads(data[4:4 + length])
        # The image: the top-left pixel everywhere, then each row's span of kept pixels.
        width, height, at = reply["width"], reply["height"], 4 + length
        fill, image = data[at:at + 4], bytearray(data[at:at + 4] * (width * height))
        spans, at = data[at + 4:at + 4 + 4 * height], at + 4 + 4 * height
        for y in range(height):
            first, count = int.from_bytes(spans[4 * y:4 * y + 2], "little"), int.from_bytes(spans[4 * y + 2:4 * y + 4], "little")
            image[4 * (y * width + first):4 * (y * width + first + count)] = data[at:at + 4 * count]
            at += 4 * count
        assert at == len(data) and image[:4] == fill
        return status, reply, bytes(image)

    def close(self):
        self.process.terminate()
        self.process.wait(timeout=30)


@pytest.fixture(scope="module")
def mesh(tmp_path_factory):
    d = tmp_path_factory.mktemp("view")
    vertices, triangles = terrain(60)
    write_obj(d / "t.obj", vertices, triangles)
    return d / "t.obj"


def crc_of(command: str, cwd: Path) -> str:
    """Run a command line the page shows, with `--stats`: the colour layer's CRC-32 it prints."""
    args = shlex.split(command)
    assert args[:2] == ["tileraster", "render"], command
    out = subprocess.run([str(binary()), *args[1:], "--stats", "--quiet"], cwd=cwd, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return json.loads([line for line in out.stderr.splitlines() if '"checksums"' in line][-1])["checksums"]["colour"]


def test_the_viewer_in_a_browser(mesh, tmp_path):
    sync_playwright = browser_or_fail()
    if sync_playwright is None:
        return
    server = Server(mesh, "--backend", "cpu", "--size", "480", "320", "--background", "30,30,40,255", "--shading", "flat")
    assert server.host == "127.0.0.1", "the viewer listens on this machine only by default"
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": 1000, "height": 480})
            page.goto(server.url)

            def settled():
                page.wait_for_function("window.viewer.frames > 0 && window.viewer.idle", timeout=60_000)
                return page.text_content("#crc"), page.text_content("#command")

            def canvas_crc():
                """The CRC-32 of the canvas's own pixels, read back in the page (exact for the
                opaque pixels of these frames)."""
                return page.evaluate("""() => {
                    const c = document.getElementById("frame"), bytes = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
                    const table = Array.from({ length: 256 }, (_, n) => { for (let k = 0; k < 8; k++) n = n & 1 ? 0xedb88320 ^ (n >>> 1) : n >>> 1; return n >>> 0; });
                    let crc = 0xffffffff;
                    for (let i = 0; i < bytes.length; i++) crc = table[(crc ^ bytes[i]) & 0xff] ^ (crc >>> 8);
                    return ((crc ^ 0xffffffff) >>> 0).toString(16).padStart(8, "0");
                }""")

            def shown_is_reproduced():
                crc, command = settled()
                assert crc == crc_of(command, tmp_path), command
                return crc, command

            crc, command = shown_is_reproduced()
            assert canvas_crc() == crc, "the canvas holds the engine's bytes"
            assert "--camera" not in command and "--backend cpu" in command and "--size 480 320" in command
            assert "--shading flat" in command, "the page starts from the command line's options"
            assert page.eval_on_selector("#frame", "c => [c.width, c.height]") == [480, 320]

            # A drag rotates the model: another frame, drawn from a look-at camera.
            box = page.locator("#frame").bounding_box()
            x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
            page.mouse.move(x, y)
            page.mouse.down()
            page.mouse.move(x + 120, y + 30, steps=6)
            page.mouse.up()
            dragged, command = shown_is_reproduced()
            assert dragged != crc and "--camera" in command
            assert canvas_crc() == dragged

            # The wheel zooms, a right-drag pans, W moves: each a new camera.
            page.mouse.move(x, y)
            page.mouse.wheel(0, -300)
            zoomed, command = shown_is_reproduced()
            page.mouse.down(button="right")
            page.mouse.move(x + 40, y - 20, steps=4)
            page.mouse.up(button="right")
            panned, _ = shown_is_reproduced()
            page.keyboard.press("w")
            moved, _ = shown_is_reproduced()
            assert len({dragged, zoomed, panned, moved}) == 4

            # The reference CRC: saved, then a change differs and the way back matches.
            page.keyboard.press("c")
            assert "saved" in page.text_content("#check")
            reference = page.text_content("#crc")
            steps = [("f", "--backend cpu"), ("f", "--shading phong"), ("f", "--shading pbr"), ("m", "--wireframe diamond-exit"), ("v", "--points 3"), ("x", "--msaa 4"), ("p", "--ortho="),
                     ("p", "--projection cylindrical"), ("p", "--projection equirectangular"), ("p", "--projection fisheye")]
            for key, flag in steps:
                page.keyboard.press(key)
                shown, command = shown_is_reproduced()
                assert flag in command, (key, command)
                assert "≠ the reference" in page.text_content("#check")
            for key in ["p", "x", "x", "v", "m", "f"]:
                page.keyboard.press(key)
                settled()
            assert page.text_content("#crc") == reference and page.text_content("#check") == "= the reference"

            # Jitter, and temporal accumulation once the camera rests.
            page.keyboard.press("j")
            _, command = shown_is_reproduced()
            assert "--jitter 8" in command
            page.keyboard.press("j")
            page.keyboard.press("t")
            page.wait_for_function("document.getElementById('command').textContent.includes('--jitter 32')", timeout=60_000)
            _, command = shown_is_reproduced()
            assert "--jitter 32" in command and page.text_content("#crc") != reference
            page.keyboard.press("t")
            assert shown_is_reproduced()[0] == reference

            # The heat map: its own image, and the command line that writes it.
            page.keyboard.press("h")
            settled()
            assert page.eval_on_selector("#frame", "c => [c.width, c.height]") != [480, 320]
            assert "--heat-map heat.png" in page.text_content("#command")
            page.keyboard.press("h")
            settled()

            # The help overlay hides and shows.
            assert page.is_visible("#help")
            page.keyboard.press("?")
            assert not page.is_visible("#help")
            page.keyboard.press("?")

            # The GPU backend: the same frame, the same CRC.
            page.keyboard.press("b")
            settled()
            if page.text_content("#error"):
                assert os.environ.get("TILERASTER_SKIP_GPU") == "1", page.text_content("#error")
                print("SKIPPED (TILERASTER_SKIP_GPU=1): the viewer's GPU backend: " + page.text_content("#error"))
            else:
                assert page.text_content("#backend") == "gpu" and page.text_content("#crc") == reference
                assert "--backend gpu" in page.text_content("#command")
            page.screenshot(path=str(tmp_path / "viewer.png"))
            assert (tmp_path / "viewer.png").stat().st_size > 10_000
            browser.close()
    finally:
        server.close()


def test_the_server_answers_bad_requests_and_goes_on(mesh):
    server = Server(mesh, "--backend", "cpu", "--size", "160", "120")
    try:
        status, page = server.request("GET", "/")
        assert status == 200 and b"tileraster view" in page
        status, reply, pixels = server.frame()
        assert status == 200 and reply["width"] == 160 and reply["command"].startswith("tileraster render ")
        assert f"{zlib.crc32(pixels):08x}" == reply["crc"], "the spans rebuild the frame's bytes"
        bad = [
            ("GET", "/../../etc/passwd", None, 404),
            ("GET", "/frame", None, 405),
            ("POST", "/frame", "{", 400),
            ("POST", "/frame", json.dumps({"colour": "red"}), 400),
            ("POST", "/frame", json.dumps({"size": [100000, 10]}), 400),
            ("POST", "/frame", json.dumps({"size": [4096, 4096], "msaa": 8}), 400),
            ("POST", "/frame", json.dumps({"msaa": 3}), 400),
            ("POST", "/frame", json.dumps({"shading": "toon"}), 400),
            ("POST", "/frame", json.dumps({"backend": "tpu"}), 400),
            ("POST", "/frame", json.dumps({"camera": {"eye": [1, 1, 1], "target": [1, 1, 1], "up": [0, 0, 1]}}), 400),
            ("POST", "/frame", json.dumps({"camera": {"eye": [1e308, 0, 0], "target": [0, 0, 0], "up": [0, 0, 1]}}), None),
            ("POST", "/frame", "x" * 100_000, 413),
        ]
        for method, path, body, want in bad:
            status, data = server.request(method, path, body, {"Content-Type": "application/json"})
            if want is None:
                assert status in (200, 400, 422), (path, body[:80], status)
            else:
                assert status == want, (method, path, (body or "")[:80], status, data[:200])
            if status != 200:
                assert data and b"panicked" not in data
        # Connections beyond the bound are closed at once; the server goes on.
        idle = [socket.create_connection((server.host, int(server.port))) for _ in range(40)]
        time.sleep(0.5)
        extra = socket.create_connection((server.host, int(server.port)))
        extra.settimeout(5)
        extra.sendall(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n")
        try:
            answered = extra.recv(64)
        except (ConnectionResetError, socket.timeout):
            answered = b""
        assert answered == b"", "a connection over the bound is closed"
        for s in idle + [extra]:
            s.close()
        time.sleep(0.5)
        status, reply, _ = server.frame(shading="flat")
        assert status == 200 and "--shading flat" in reply["command"]
        assert server.process.poll() is None
    finally:
        server.close()


def test_the_viewer_listens_where_it_is_told(mesh):
    server = Server(mesh, "--backend", "cpu", "--size", "64", "48", "--listen", "0.0.0.0")
    try:
        assert server.host == "0.0.0.0"
        status, reply, _ = server.frame()
        assert status == 200
    finally:
        server.close()
