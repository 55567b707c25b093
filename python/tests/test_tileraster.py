"""tileraster for Python: the same bits as the command line and on both backends, numpy dtypes
and layouts, windows and prepared scenes, errors with the library's messages, Ctrl-C.

The command line is the binary cargo built (`TILERASTER_BIN`, or target/debug or
target/release in the repository). GPU checks need a Vulkan adapter (lavapipe counts);
`TILERASTER_SKIP_GPU=1` skips them, and says so.
"""

from __future__ import annotations

import ast
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import tileraster

REPO = Path(__file__).resolve().parents[2]


def binary() -> Path:
    candidates = [os.environ.get("TILERASTER_BIN")] + [str(REPO / "target" / p / "tileraster") for p in ("debug", "release")]
    for c in candidates:
        if c and Path(c).is_file():
            return Path(c)
    pytest.fail("no tileraster binary: run `cargo build` (or set TILERASTER_BIN)")


def terrain(n: int = 40, seed: int = 3):
    """A jittered lattice TIN over 1000 × 600 map units, heights a smooth surface."""
    rng = np.random.default_rng(seed)
    xs, ys = np.meshgrid(np.linspace(0, 1000, n), np.linspace(0, 600, n))
    x = xs.ravel() + rng.uniform(-3, 3, xs.size)
    y = ys.ravel() + rng.uniform(-3, 3, ys.size)
    z = 50 + 20 * np.sin(x / 150) * np.cos(y / 90)
    vertices = np.round(np.column_stack([x, y, z]), 3)
    quads = [(j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1) for j in range(n - 1) for i in range(n - 1)]
    triangles = np.array([t for a, b, c, d in quads for t in ((a, b, c), (b, d, c))], dtype=np.int64)
    return vertices, triangles


def write_obj(path: Path, vertices, triangles):
    with open(path, "w") as f:
        for v in vertices:
            f.write("v %r %r %r\n" % tuple(float(c) for c in v))
        for t in triangles:
            f.write("f %d %d %d\n" % tuple(int(i) + 1 for i in t))


GRID_ARGS = ["--txe", "-20", "1010", "--tye", "-10", "610", "--outsize", "300", "180"]
GRID = tileraster.Grid(txe=(-20, 1010), tye=(-10, 610), outsize=(300, 180))


def cli(*args) -> subprocess.CompletedProcess:
    out = subprocess.run([str(binary()), *map(str, args)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return out


def test_the_same_file_as_the_command_line(tmp_path):
    vertices, triangles = terrain()
    obj = tmp_path / "m.obj"
    write_obj(obj, vertices, triangles)
    cli("rasterise", obj, "-o", tmp_path / "cli.tif", "--owner", tmp_path / "cli-owner.tif", "--backend", "cpu", *GRID_ARGS)
    raster = tileraster.rasterise(vertices, triangles, GRID, backend="cpu", owner=True)
    raster.write(tmp_path / "py.tif")
    raster.write(tmp_path / "py-owner.tif", owner=True)
    assert (tmp_path / "py.tif").read_bytes() == (tmp_path / "cli.tif").read_bytes()
    assert (tmp_path / "py-owner.tif").read_bytes() == (tmp_path / "cli-owner.tif").read_bytes()
    # Compressed, tiled, with a CRS: the same options give the same file.
    cli("rasterise", obj, "-o", tmp_path / "cli-c.tif", "--backend", "cpu", "--a_srs", "EPSG:32633", "--co", "COMPRESS=DEFLATE",
        "--co", "TILED=YES", *GRID_ARGS)
    raster.write(tmp_path / "py-c.tif", epsg=32633, creation_options=["COMPRESS=DEFLATE", "TILED=YES"])
    assert (tmp_path / "py-c.tif").read_bytes() == (tmp_path / "cli-c.tif").read_bytes()


def test_points_give_the_command_lines_dem(tmp_path):
    vertices, _ = terrain(seed=8)
    # A repeated position with another height: the first is kept, as on the command line.
    points = np.vstack([vertices, vertices[:5] + [0, 0, 100]])
    csv = tmp_path / "p.csv"
    np.savetxt(csv, points, delimiter=",", header="x,y,z", comments="", fmt="%.17g")
    cli("rasterise", csv, "-o", tmp_path / "cli.tif", "--backend", "cpu", "--tr", "2", "2", "--tap", "--max-edge", "40")
    dem = tileraster.points_to_dem(points, tileraster.Grid(tr=(2, 2), tap=True), backend="cpu", max_edge=40)
    dem.write(tmp_path / "py.tif")
    assert (tmp_path / "py.tif").read_bytes() == (tmp_path / "cli.tif").read_bytes()
    assert dem.transform[0] == 2 and dem.transform[2] % 2 == 0 and dem.transform[5] % 2 == 0
    # gdal_grid's linear:radius, as the command line's -a.
    cli("rasterise", csv, "-o", tmp_path / "cli-r.tif", "--backend", "cpu", "--tr", "2", "2", "--tap", "--max-edge", "40", "-a",
        "linear:radius=30")
    near = tileraster.points_to_dem(points, tileraster.Grid(tr=(2, 2), tap=True), backend="cpu", max_edge=40, radius=30)
    near.write(tmp_path / "py-r.tif")
    assert (tmp_path / "py-r.tif").read_bytes() == (tmp_path / "cli-r.tif").read_bytes()
    assert (near.values != -9999).sum() > (dem.values != -9999).sum() and near.owner is None
    tin = tileraster.tin(points)
    assert len(tin.vertices) == len(vertices) and len(tin) > 0
    assert np.array_equal(tileraster.rasterise(tin, None, tileraster.Grid(tr=(2, 2), tap=True), backend="cpu").values,
                          tileraster.points_to_dem(points, tileraster.Grid(tr=(2, 2), tap=True), backend="cpu").values)


def gpu_or_skip():
    _, adapter = tileraster.backends()
    if adapter is not None:
        return True
    if os.environ.get("TILERASTER_SKIP_GPU") == "1":
        print("SKIPPED: no Vulkan adapter and TILERASTER_SKIP_GPU=1: the GPU backend was not compared")
        return False
    pytest.fail("no Vulkan adapter: install one (lavapipe: mesa-vulkan-drivers), or set TILERASTER_SKIP_GPU=1 to skip GPU checks")


def test_cpu_and_gpu_give_the_same_bits():
    if not gpu_or_skip():
        return
    vertices, triangles = terrain(60)
    for mode in ("exact", "plane-f32", "barycentric"):
        cpu = tileraster.rasterise(vertices, triangles, GRID, backend="cpu", mode=mode, owner=True)
        gpu = tileraster.rasterise(vertices, triangles, GRID, backend="gpu", mode=mode, owner=True)
        assert cpu.values.tobytes() == gpu.values.tobytes(), mode
        assert cpu.owner.tobytes() == gpu.owner.tobytes(), mode
        assert cpu.bands == gpu.bands, mode


def test_arrays_in_any_layout_and_dtype_give_the_same_raster():
    vertices, triangles = terrain()
    expected = tileraster.rasterise(vertices, triangles, GRID, backend="cpu", owner=True)
    assert expected.values.dtype == np.float32 and expected.values.shape == (180, 300) and expected.values.flags.c_contiguous
    assert expected.owner.dtype == np.uint32 and expected.owner.shape == (180, 300)
    assert (expected.owner == 4294967295).any() and (expected.owner < len(triangles)).any()
    assert ((expected.values == -9999.0) == (expected.owner == 4294967295)).all()
    for v, t in [
        (np.asfortranarray(vertices), np.asfortranarray(triangles)),
        (vertices, triangles.astype(np.int32)),
        (vertices, triangles.astype(np.uint32)),
        (vertices.tolist(), triangles.tolist()),
        (np.repeat(vertices, 2, axis=0)[::2], np.repeat(triangles, 3, axis=1)[:, ::3]),
    ]:
        assert np.array_equal(np.asarray(v, dtype=float), vertices)
        got = tileraster.rasterise(v, t, GRID, backend="cpu", owner=True)
        assert got.values.tobytes() == expected.values.tobytes()
        assert got.owner.tobytes() == expected.owner.tobytes()
    # float32 coordinates are taken at their value.
    v32 = vertices.astype(np.float32)
    assert (tileraster.rasterise(v32, triangles, GRID, backend="cpu").values.tobytes()
            == tileraster.rasterise(v32.astype(np.float64), triangles, GRID, backend="cpu").values.tobytes())


def test_windows_prepared_scenes_and_georeferencing():
    vertices, triangles = terrain()
    whole = tileraster.rasterise(vertices, triangles, GRID, backend="cpu")
    assert whole.geotransform == (-20.0, 1030 / 300, 0.0, 610.0, 0.0, -620 / 180)
    assert whole.transform == (1030 / 300, 0.0, -20.0, 0.0, -620 / 180, 610.0)
    assert whole.bounds == (-20.0, -10.0, 1010.0, 610.0)
    window = tileraster.rasterise(vertices, triangles, GRID, backend="cpu", window=(40, 30, 100, 50))
    assert np.array_equal(window.values, whole.values[30:80, 40:140])
    assert window.geotransform[0] == -20 + 40 * (1030 / 300) and window.geotransform[3] == 610 - 30 * (620 / 180)
    scene = tileraster.Scene(vertices, triangles)
    again = tileraster.Scene(scene.vertices, scene.triangles)  # uint32 triangles back in
    assert again.triangles.tobytes() == scene.triangles.tobytes()
    prepared = tileraster.Prepared(again, GRID, backend="cpu")
    for w in [(0, 0, 300, 180), (250, 170, 50, 10), (7, 9, 1, 1)]:
        x0, y0, width, height = w
        assert prepared.rasterise(w).values.tobytes() == np.ascontiguousarray(whole.values[y0:y0 + height, x0:x0 + width]).tobytes()
    assert prepared.rasterise().values.tobytes() == whole.values.tobytes()
    [stats] = whole.bands
    assert stats["tiles_total"] == 19 * 12 and "fine_raster" in stats["passes"], stats  # 16 × 16-cell tiles
    assert whole.stats == {**stats, "bands": 1}
    # The command line's `--stats` fields, every one (a heightfield bins every triangle it
    # does not cull).
    assert set(stats) == {
        "tiles_total", "tiles_empty_skipped", "tiles_full", "tiles_partial", "triangles_culled", "triangles_flat",
        "triangles_binned", "triangles_small", "triangles_hidden", "overlap_free", "passes", "bytes_uploaded",
    }, stats
    assert stats["triangles_small"] == stats["triangles_hidden"] == 0, stats


def test_large_windows_run_in_bands_with_the_same_cells():
    vertices, triangles = terrain(20)
    grid = tileraster.Grid(txe=(0, 1000), tye=(0, 600), outsize=(4100, 4200))
    whole = tileraster.rasterise(vertices, triangles, grid, backend="cpu")
    assert len(whole.bands) == 2, "17.2M cells run in two bands"
    assert whole.stats["bands"] == 2
    assert whole.stats["tiles_total"] == sum(b["tiles_total"] for b in whole.bands) == 257 * 263
    top = tileraster.rasterise(vertices, triangles, grid, backend="cpu", window=(0, 0, 4100, 2100))
    assert np.array_equal(whole.values[:2100], top.values)


def test_bad_input_raises_the_librarys_errors(tmp_path):
    vertices, triangles = terrain(5)
    cases = [
        (lambda: tileraster.rasterise(vertices, np.array([[0, 1, 99]]), GRID), "triangle 0 refers to vertex 99"),
        (lambda: tileraster.rasterise(vertices, np.array([[0, -1, 2]]), GRID), "triangle 0 has vertex index -1"),
        (lambda: tileraster.rasterise(vertices[:, :2], triangles, GRID), "vertices has shape (25, 2); give an (N, 3) array"),
        (lambda: tileraster.rasterise(vertices, triangles.astype(float), GRID), "give integer vertex indices"),
        (lambda: tileraster.rasterise(np.where(np.arange(75).reshape(25, 3) == 4, np.nan, vertices), triangles, GRID), "vertex 1 has a non-finite y coordinate (NaN)"),
        (lambda: tileraster.Grid(txe=(0, 1), tye=(0, 1), outsize=(0, 10)), "raster size 0×10 is empty"),
        (lambda: tileraster.Grid(txe=(0, 1), tye=(0, 1)), "give the raster size as outsize=(width, height) or the cell size"),
        (lambda: tileraster.Grid(outsize=(10, 10), tap=True), "--tap aligns the extent to the cell size"),
        (lambda: tileraster.rasterise(vertices, triangles, GRID, backend="tpu"), "backend 'tpu'"),
        (lambda: tileraster.rasterise(vertices, triangles, GRID, mode="cubic"), "cubic"),
        (lambda: tileraster.points_to_dem(np.zeros((3, 3)), GRID), "distinct point"),
        (lambda: tileraster.tin(vertices, max_edge=-1), "--max-edge is -1"),
        (lambda: tileraster.rasterise(vertices, triangles, GRID).write(tmp_path / "o.tif", owner=True), "no owner layer"),
        (lambda: tileraster.rasterise(vertices, triangles, GRID).write(tmp_path / "o.tif", creation_options=["COMPRESS=JPEG"]), "unsupported creation option"),
        (lambda: tileraster.rasterise(vertices, triangles, GRID).write(tmp_path / "no" / "such" / "dir.tif"), "dir.tif"),
    ]
    for call, message in cases:
        with pytest.raises(tileraster.TilerasterError) as e:
            call()
        assert message in str(e.value), (message, str(e.value))
    assert issubclass(tileraster.TilerasterError, ValueError)
    assert list(tmp_path.iterdir()) == [], "a refused write leaves no file"


def test_ctrl_c_stops_a_long_call():
    # One call of a few seconds (2M triangles onto 16384² cells); the signal lands inside it,
    # and KeyboardInterrupt must come well before the call would have ended.
    script = (
        "import numpy as np, signal, time, tileraster\n"
        # Ctrl-C as an interactive Python has it, even where this test runs with SIGINT
        # ignored (a shell's background job: Python then installs no handler of its own).
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "n = 1000\n"
        "xs, ys = np.meshgrid(np.linspace(0, 1000, n), np.linspace(0, 1000, n))\n"
        "v = np.column_stack([xs.ravel(), ys.ravel(), np.random.default_rng(1).uniform(0, 10, n * n)])\n"
        "q = np.arange((n - 1) * (n - 1)); a = (q // (n - 1)) * n + q % (n - 1)\n"
        "t = np.concatenate([np.column_stack([a, a + 1, a + n]), np.column_stack([a + 1, a + n + 1, a + n])])\n"
        "scene = tileraster.Scene(v, t)\n"
        "g = tileraster.Grid(txe=(0, 1000), tye=(0, 1000), outsize=(16384, 16384))\n"
        "start = time.monotonic()\n"
        "if __import__('sys').argv[1] == 'time':\n"
        "    tileraster.rasterise(scene, None, g, backend='cpu'); print(time.monotonic() - start, flush=True); raise SystemExit\n"
        "print('started', flush=True)\n"
        "tileraster.rasterise(scene, None, g, backend='cpu')\n"
        "print('finished', flush=True)\n"
    )
    whole = float(subprocess.run([sys.executable, "-c", script, "time"], capture_output=True, text=True, check=True).stdout)
    # The signal lands a quarter into the call and the interrupt must come within half of it, so
    # the call need only be long enough for that to be told apart from scheduling noise.
    assert whole > 1.0, f"the call takes {whole:.1f} s: too short to interrupt inside it"
    child = subprocess.Popen([sys.executable, "-c", script, "go"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "started"
    time.sleep(whole / 4)
    child.send_signal(signal.SIGINT)
    sent = time.monotonic()
    out, err = child.communicate(timeout=120)
    took = time.monotonic() - sent
    assert "finished" not in out and "KeyboardInterrupt" in err, err
    assert took < min(1.0, whole / 2), f"KeyboardInterrupt {took:.2f} s after the signal, in a call of {whole:.1f} s"
    assert child.returncode != 0


def test_the_readme_example_runs(tmp_path, monkeypatch):
    """The README's Python example, as written there, on a LAS file made here."""
    import laspy  # noqa: the README's example reads LAS with laspy and writes with rasterio
    import rasterio
    vertices, _ = terrain(30)
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales = [0.001, 0.001, 0.001]
    las = laspy.LasData(header)
    las.x, las.y, las.z = vertices[:, 0], vertices[:, 1], vertices[:, 2]
    las.classification = np.where(np.arange(len(vertices)) % 5 == 0, 5, 2).astype(np.uint8)
    las.write(tmp_path / "points.las")
    readme = (REPO / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", readme, re.S)
    assert len(blocks) >= 2, "the README shows the Python examples"
    monkeypatch.chdir(tmp_path)
    namespace = {}
    for block in blocks[:2]:
        exec(compile(block, "README.md", "exec"), namespace)
    with rasterio.open(tmp_path / "dem.tif") as ours, rasterio.open(tmp_path / "dem-rasterio.tif") as theirs:
        a, b = ours.read(1), theirs.read(1)
        assert a.tobytes() == b.tobytes() and ours.transform == theirs.transform and ours.nodata == theirs.nodata


def test_auto_decides_without_a_device_and_prints_no_error(tmp_path):
    """The default backend on a fresh process: the adapters surveyed (or read back from the
    cache the first process kept), no device opened for a raster the CPU takes, and no line on
    stderr that says error."""
    code = (
        "import numpy as np, tileraster\n"
        "pts = np.random.default_rng(1).uniform(0, 100, (500, 3))\n"
        "dem = tileraster.points_to_dem(pts, tileraster.Grid(tr=(1, 1)))\n"
        "assert dem.values.shape == (100, 100)\n"
        "print(tileraster.backends())\n"
    )
    env = dict(os.environ, TILERASTER_CACHE_DIR=str(tmp_path / "cache"))
    env.pop("XDG_RUNTIME_DIR", None)
    for run in ("surveyed", "read back"):
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
        assert out.returncode == 0, (run, out.stderr)
        assert "error" not in out.stderr.lower(), (run, out.stderr)
        choice, adapter = ast.literal_eval(out.stdout.strip())
        assert choice in ("cpu", "gpu"), out.stdout
