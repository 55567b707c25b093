"""tileraster.render and tileraster.Renderer: the command line's bytes for the same options,
numpy meshes of any layout, the GIL released while a frame is drawn, and typed errors."""

from __future__ import annotations

import base64
import json
import re
import struct
import threading
import zlib

import numpy as np
import pytest

import tileraster
from test_tileraster import REPO, cli, gpu_or_skip, terrain, write_obj


def crcs(frame: tileraster.Frame) -> dict:
    """CRC-32 of the numpy layers' own bytes (not the library's checksums of its buffers)."""
    return {name: f"{zlib.crc32(getattr(frame, name).tobytes()):08x}" for name in ("colour", "depth", "ids")}


def cli_crcs(mesh, tmp_path, *args) -> dict:
    """The command line's frame of `mesh` with `args`: the CRC-32 of each layer `--stats` prints."""
    out = cli("render", mesh, "-o", tmp_path / "cli.png", "--stats", "--backend", "cpu", "--quiet", *args)
    stats = json.loads([line for line in out.stderr.splitlines() if '"checksums"' in line][-1])
    return {name: stats["checksums"][name] for name in ("colour", "depth", "ids")}


def write_gltf(path, camera_translation=(0.3, 0.2, 3.0)):
    """A quad in the z = 0 plane and a perspective camera node named "eye" looking down −Z."""
    positions = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype="<f4")
    indices = np.array([0, 1, 2, 0, 2, 3], dtype="<u2")
    blob = positions.tobytes() + indices.tobytes()
    gltf = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 12}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.1, "zfar": 100, "aspectRatio": 1.5}}],
        "nodes": [{"mesh": 0}, {"name": "eye", "camera": 0, "translation": list(camera_translation)}],
        "scenes": [{"nodes": [0, 1]}],
        "scene": 0,
    }
    path.write_text(json.dumps(gltf))


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """An OBJ terrain, its DEM as a GeoTIFF, a glTF file with a camera, and an instances file."""
    d = tmp_path_factory.mktemp("render")
    vertices, triangles = terrain(30)
    write_obj(d / "t.obj", vertices, triangles)
    cli("rasterise", d / "t.obj", "-o", d / "t.tif", "--tr", "25", "25", "--backend", "cpu", "--quiet")
    write_gltf(d / "q.gltf")
    transforms = [np.eye(4), np.array([[1, 0, 0, 1100], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], float)]
    (d / "two.txt").write_text("\n".join(" ".join(repr(float(v)) for v in m.ravel()) for m in transforms))
    return {"obj": d / "t.obj", "dem": d / "t.tif", "gltf": d / "q.gltf", "instances": d / "two.txt", "transforms": transforms,
            "vertices": vertices, "triangles": triangles}


# (file, command-line options, the same as keyword arguments)
CASES = [
    ("obj", [], {}),
    ("obj", ["--shading", "phong", "--msaa", "4", "--size", "200", "120"], {"shading": "phong", "msaa": 4, "size": (200, 120)}),
    ("obj", ["--camera", "500,-900,600,500,300,40,0,0,1", "--fov", "30", "--cull", "none"],
     {"camera": ((500, -900, 600), (500, 300, 40), (0, 0, 1)), "fov": 30, "cull": "none"}),
    ("obj", ["--ortho", "--up", "z", "--shading", "depth"], {"ortho": True, "up": "z", "shading": "depth"}),
    ("obj", ["--ortho", "700", "--size", "160", "160", "--background", "10,20,30,255"],
     {"ortho": 700, "size": (160, 160), "background": (10, 20, 30, 255)}),
    ("obj", ["--wireframe", "bresenham", "--points", "3", "--wire-colour", "255,0,0,255", "--size", "300", "200"],
     {"wireframe": "bresenham", "points": 3, "wire_colour": (255, 0, 0, 255), "size": (300, 200)}),
    ("obj", ["--z-scale", "3", "--shading", "flat"], {"z_scale": 3, "shading": "flat"}),
    ("obj", ["--shading", "pbr", "--metallic", "1", "--roughness", "0.3"], {"shading": "pbr", "metallic": 1.0, "roughness": 0.3}),
    ("obj", ["--shading", "pbr", "--tone-map", "aces", "--srgb"], {"shading": "pbr", "tone_map": "aces", "srgb": True}),
    ("obj", ["--instances", "INSTANCES", "--shading", "ids"], {"instances": "TRANSFORMS", "shading": "ids"}),
    ("obj", ["--jitter", "4", "--size", "160", "100"], {"jitter": 4, "size": (160, 100)}),
    ("obj", ["--projection", "equirectangular", "--camera", "500,300,120,600,300,100,0,0,1", "--size", "256", "128"],
     {"projection": "equirectangular", "camera": ((500, 300, 120), (600, 300, 100), (0, 0, 1)), "size": (256, 128)}),
    ("obj", ["--projection", "fisheye", "--fov", "220", "--camera", "500,300,300,500,300,0,0,1,0", "--size", "160", "160"],
     {"projection": "fisheye", "fov": 220, "camera": ((500, 300, 300), (500, 300, 0), (0, 1, 0)), "size": (160, 160)}),
    ("obj", ["--projection", "cylindrical", "--camera", "500,300,120,600,300,100,0,0,1", "--size", "240", "80", "--cull", "none"],
     {"projection": "cylindrical", "camera": ((500, 300, 120), (600, 300, 100), (0, 0, 1)), "size": (240, 80), "cull": "none"}),
    ("dem", ["--size", "320", "200"], {"size": (320, 200)}),
    ("dem", ["--points", "2", "--no-faces", "--size", "320", "200"], {"points": 2, "faces": False, "size": (320, 200)}),
    ("gltf", ["--camera-node", "eye", "--cull", "none"], {"camera_node": "eye", "cull": "none"}),
    ("gltf", ["--camera-node", "1", "--shading", "normals", "--interpolation", "flat"], {"camera_node": 1, "shading": "normals", "interpolation": "flat"}),
]


@pytest.mark.parametrize("case", range(len(CASES)))
def test_render_gives_the_command_lines_bytes(files, tmp_path, case):
    name, args, options = CASES[case]
    args = [str(files["instances"]) if a == "INSTANCES" else a for a in args]
    options = {k: files["transforms"] if v == "TRANSFORMS" else v for k, v in options.items()}
    want = cli_crcs(files[name], tmp_path, *args)
    frame = tileraster.render(files[name], backend="cpu", **options)
    assert crcs(frame) == want
    assert frame.stats["pixels_covered"] > 0
    # A Renderer of the same file gives the same frame (its model options at construction).
    model = {k: options.pop(k) for k in ("z_scale", "instances") if k in options}
    renderer = tileraster.Renderer(files[name], points="points" in options, **model)
    assert crcs(renderer.render(backend="cpu", **options)) == want


def test_numpy_meshes_in_any_layout_give_the_files_frame(files):
    vertices, triangles = files["vertices"], files["triangles"]
    want = crcs(tileraster.render(files["obj"], backend="cpu", shading="phong", size=(240, 160)))
    # Every dtype and layout the DEM API takes: Fortran order, 32-bit and unsigned indices,
    # lists, strided views.
    for positions, faces in [
        (vertices, triangles),
        (np.asfortranarray(vertices), np.asfortranarray(triangles)),
        (vertices, triangles.astype(np.int32)),
        (vertices, triangles.astype(np.uint32)),
        (vertices.tolist(), triangles.tolist()),
        (np.repeat(vertices, 2, axis=0)[::2], np.repeat(triangles, 3, axis=1)[:, ::3]),
    ]:
        assert crcs(tileraster.render((positions, faces), backend="cpu", shading="phong", size=(240, 160))) == want
        mesh = tileraster.Mesh(positions, faces)
        assert len(mesh) == len(triangles)
        assert crcs(tileraster.render(mesh, backend="cpu", shading="phong", size=(240, 160))) == want
    # float32 positions are taken at their value.
    v32 = vertices.astype(np.float32)
    assert crcs(tileraster.render((v32, triangles), backend="cpu", size=(120, 80))) == crcs(
        tileraster.render((v32.astype(np.float64), triangles), backend="cpu", size=(120, 80)))
    # Colours as bytes or as floats in [0, 1] are the same colours; with normals and uvs.
    n = len(vertices)
    rng = np.random.default_rng(1)
    rgb = rng.integers(0, 256, (n, 3), dtype=np.uint8)
    normals = np.tile([0.0, 0.0, 1.0], (n, 1))
    uvs = vertices[:, :2] / 1000
    as_bytes = tileraster.Mesh(vertices, triangles, colours=rgb, normals=normals, uvs=uvs)
    as_floats = tileraster.Mesh(vertices, triangles, colours=np.column_stack([rgb / 255, np.ones(n)]), normals=normals.astype(np.float32), uvs=uvs)
    a = tileraster.render(as_bytes, backend="cpu", size=(200, 120), shading="unlit")
    b = tileraster.render(as_floats, backend="cpu", size=(200, 120), shading="unlit")
    assert crcs(a) == crcs(b)
    assert len(np.unique(a.colour.reshape(-1, 4), axis=0)) > 100, "the vertex colours are drawn"


def test_a_renderer_draws_many_frames_and_ids_index_the_faces(files):
    vertices, triangles = files["vertices"], files["triangles"]
    renderer = tileraster.Renderer((vertices, triangles))
    centre = vertices.mean(axis=0)
    for k in range(4):
        a = np.radians(90 * k + 20)
        camera = (centre + 1500 * np.array([np.cos(a), np.sin(a), 0.6]), centre, (0, 0, 1))
        frame = renderer.render(backend="cpu", size=(160, 120), camera=camera, shading="ids")
        assert crcs(frame) == crcs(tileraster.render((vertices, triangles), backend="cpu", size=(160, 120), camera=camera, shading="ids"))
        shown = np.unique(frame.ids)
        assert shown[-1] == tileraster.Frame.NO_FACE and shown[:-1].max() < len(triangles) and len(shown) > 50
        assert frame.colour.shape == (120, 160, 4) and frame.colour.dtype == np.uint8
        assert frame.depth.shape == (120, 160) and frame.depth.dtype == np.float32 and frame.ids.dtype == np.uint32
        # The layers are the library's buffers handed over, not copies.
        assert not frame.colour.flags["OWNDATA"] and frame.colour.base is not None


def test_cpu_and_gpu_frames_are_the_same_bits(files):
    if not gpu_or_skip():
        return
    for name, options in [("obj", {"shading": "phong", "msaa": 4}), ("dem", {}), ("gltf", {"camera_node": "eye", "cull": "none"})]:
        cpu = tileraster.render(files[name], backend="cpu", size=(256, 160), **options)
        gpu = tileraster.render(files[name], backend="gpu", size=(256, 160), **options)
        assert crcs(cpu) == crcs(gpu), name
        renderer = tileraster.Renderer(files[name])
        assert crcs(renderer.render(backend="gpu", size=(256, 160), **options)) == crcs(cpu), name


def test_a_frame_is_drawn_without_the_gil(files):
    vertices, triangles = terrain(200)
    renderer = tileraster.Renderer((vertices, triangles))
    renderer.render(backend="cpu", size=(64, 64))
    done, turns = [], 0
    worker = threading.Thread(target=lambda: done.append(renderer.render(backend="cpu", size=(1920, 1080), msaa=8, shading="phong")))
    worker.start()
    while worker.is_alive():
        turns += 1
    worker.join()
    assert done and done[0].stats["pixels_covered"] > 0
    # Python ran meanwhile: a call that held the GIL would let this loop turn a few times at most.
    assert turns > 1000, turns


def test_bad_input_raises_the_librarys_errors(files):
    vertices, triangles = files["vertices"], files["triangles"]
    bad = [
        (lambda: tileraster.Mesh(vertices[:, :2], triangles), "positions has shape"),
        (lambda: tileraster.Mesh(vertices, triangles + 10_000), "vertex"),
        (lambda: tileraster.Mesh(vertices, triangles.astype(float)), "integer"),
        (lambda: tileraster.Mesh(vertices, triangles, normals=np.zeros((3, 3))), "normals has shape"),
        (lambda: tileraster.Mesh(vertices, triangles, colours=np.zeros((len(vertices), 5))), "colours has shape"),
        (lambda: tileraster.render(files["obj"], shading="toon"), 'shading="toon"'),
        (lambda: tileraster.render(files["obj"], shading="pbr", metallic=2), "metallic: 2 is not a number from 0 to 1"),
        (lambda: tileraster.render(files["obj"], camera_node="eye"), "camera_node: "),
        (lambda: tileraster.render(files["gltf"], camera_node="nobody"), "no such camera node"),
        (lambda: tileraster.render(files["obj"], camera=((0, 0, 0), (0, 0, 0), (0, 0, 1))), "camera: "),
        (lambda: tileraster.render(files["obj"], camera=((0, 0, 9), (0, 0, 0), (0, 0, 1)), mvp=np.eye(4)), "give one camera"),
        (lambda: tileraster.render(files["obj"], ortho=-2), "ortho=-2"),
        (lambda: tileraster.render(files["obj"], background=(0, 0, 0, 256)), "background: 256"),
        (lambda: tileraster.render(files["obj"], z_scale=0), "z_scale: "),
        (lambda: tileraster.render(files["obj"], time=1.0), "time"),
        (lambda: tileraster.render(files["obj"], size=(0, 10)), "size: 0 × 10"),
        (lambda: tileraster.render(files["obj"], no_skip=["everything"]), "no_skip: "),
        (lambda: tileraster.render(files["obj"], backend="tpu"), 'backend="tpu"'),
        (lambda: tileraster.render(files["obj"], projection="mercator"), "projection: "),
        (lambda: tileraster.render(files["obj"], projection="equirectangular", fov=90), "fov: "),
        (lambda: tileraster.render(files["obj"], projection="fisheye", jitter=4), "jitter: "),
        (lambda: tileraster.render(files["obj"], jitter=0), "jitter: "),
        (lambda: tileraster.render(files["obj"].with_suffix(".nope")), "nope"),
        (lambda: tileraster.Renderer(files["dem"]).render(points=2), "points: "),
    ]
    for call, message in bad:
        with pytest.raises(tileraster.TilerasterError, match=re.escape(message)):
            call()
    with pytest.raises(TypeError, match="mesh: "):
        tileraster.render(42)
    with pytest.raises(TypeError):
        tileraster.render(files["obj"], colour_of_sky="blue")


def test_the_png_the_command_line_writes_holds_the_same_pixels(files, tmp_path):
    """The colour layer against the PNG file itself: its IDAT rows unfiltered by hand."""
    cli("render", files["obj"], "-o", tmp_path / "f.png", "--size", "90", "60", "--backend", "cpu", "--quiet")
    png = (tmp_path / "f.png").read_bytes()
    chunks, at = {}, 8
    while at < len(png):
        length, kind = struct.unpack(">I4s", png[at:at + 8])
        chunks.setdefault(kind, b"")
        chunks[kind] += png[at + 8:at + 8 + length]
        at += 12 + length
    width, height, depth, colour_type = struct.unpack(">IIBB", chunks[b"IHDR"][:10])
    assert (width, height, depth, colour_type) == (90, 60, 8, 6)
    raw, stride, rows, prior = zlib.decompress(chunks[b"IDAT"]), 4 * width, [], bytearray(4 * width)
    for y in range(height):
        kind, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for x in range(stride):
            a, b = line[x - 4] if x >= 4 else 0, prior[x]
            c = prior[x - 4] if x >= 4 else 0
            p = a + b - c
            paeth = a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else b if abs(p - b) <= abs(p - c) else c
            line[x] = (line[x] + [0, a, b, (a + b) // 2, paeth][kind]) & 0xFF
        rows.append(bytes(line))
        prior = line
    frame = tileraster.render(files["obj"], size=(90, 60), backend="cpu")
    assert frame.colour.tobytes() == b"".join(rows)


def test_the_readme_rendering_example_runs(tmp_path, monkeypatch):
    """The README's rendering example, as written there: its images, and the face ids it saves
    are the frames'."""
    from PIL import Image
    readme = (REPO / "README.md").read_text()
    block = next(b for b in re.findall(r"```python\n(.*?)```", readme, re.S) if "tileraster.Renderer(" in b)
    monkeypatch.chdir(tmp_path)
    exec(compile(block.replace('"tests/data/', f'"{REPO}/tests/data/'), "README.md", "exec"), {})
    renderer = tileraster.Renderer(REPO / "tests" / "data" / "autzen_trim.laz")
    for k in range(4):
        faces = np.load(tmp_path / f"faces{k}.npy")
        view = np.asarray(Image.open(tmp_path / f"view{k}.png"))
        mask = np.asarray(Image.open(tmp_path / f"mask{k}.png"))
        assert view.shape == (320, 480, 4) and faces.shape == mask.shape == (320, 480)
        assert np.array_equal(mask, faces != tileraster.Frame.NO_FACE) and 0.1 < mask.mean() < 0.9
        assert (view[mask][:, 3] == 255).all()
    assert len(np.unique(faces)) > 5000, "the TIN's faces are labelled"
    assert renderer.bounds[0][2] < renderer.bounds[1][2]
