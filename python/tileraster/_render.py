"""Rendering meshes to frames whose bits do not depend on the machine: ``render`` for one frame,
``Renderer`` for many frames of one mesh. The keyword arguments are ``tileraster render``'s
options, and the same options give the command line's bytes."""

from __future__ import annotations

import json
import os
import sys

import numpy as np

from ._native import Mesh, View
from ._native import Renderer as _Renderer
from ._native import render as _render

__all__ = ["Frame", "Mesh", "Renderer", "render"]

_VIEW_OPTIONS = """
    Keyword arguments, as ``tileraster render``'s options (its ``--help`` says more):

    - ``size=(width, height)``: pixels (default 1280 × 720, or as a glTF camera's aspect).
    - The camera, one of: ``camera=(eye, target, up)`` in the mesh's coordinates;
      ``mvp=`` a 4×4 matrix to Vulkan's clip space; ``camera_node=`` a glTF camera's node
      index or name. Default: the whole mesh framed from its front.
    - ``fov=45.0`` degrees, or ``ortho=True`` (as wide as frames the mesh) or ``ortho=WIDTH``;
      or ``projection="cylindrical"``, ``"equirectangular"`` or ``"fisheye"``: a panorama
      around the camera's eye, each pixel a pixel of a cube face drawn as an exact perspective
      frame (``fov`` is then the cylinder's height, 90, or the fisheye's width, 180);
      ``up="y"`` or ``"z"`` for the default camera (default: the format's; ``"y"`` for a
      ``Mesh``).
    - ``shading=None`` (``"pbr"`` for a file with materials, glTF or OBJ with MTL, else
      ``"smooth"``): ``"unlit"``, ``"flat"``, ``"smooth"``, ``"phong"``, ``"pbr"``,
      ``"depth"``, ``"normals"`` or ``"ids"``; ``metallic=None`` (0) and ``roughness=None``
      (0.5) for ``"pbr"`` (glTF's metallic-roughness BRDF) where the meshes have no materials
      (refused for a file whose materials give their own);
      ``tone_map="none"`` (or ``"neutral"``, ``"aces"``) and ``srgb=False`` (``True``: lit
      colours sRGB-encoded, as files and screens expect); ``interpolation="perspective"`` (or
      ``"screen"``, ``"flat"``); ``cull=None`` (back faces, but not a double-sided material's;
      ``"back"``, ``"front"`` or ``"none"``: every face as it says); ``msaa=1`` (or 4, 8);
      ``background=(r, g, b, a)`` 0..255.
    - ``points=PIXELS`` (the vertices as squares), ``wireframe=True`` (or ``"bresenham"``,
      ``"rectangle"``), ``wire_colour=(r, g, b, a)``, ``faces=False``; ``filter=``,
      ``address=`` for every texture; ``blend=True``; ``no_skip=["empty_tiles", ...]``.
    - ``jitter=N``: N frames at sub-pixel offsets averaged (anti-aliasing without MSAA).
    - ``count_fragments=True`` counts each pixel's fragments (``Frame.stats``' overdraw).
    - ``backend="auto"``: ``"cpu"``, ``"gpu"`` or ``"auto"``; both give the same bits.
"""


class Frame:
    """One rendered frame, row 0 at the top. Its arrays are the engine's buffers, not copies:

    - ``colour``: (H, W, 4) uint8 RGBA;
    - ``depth``: (H, W) float32, 1 where no triangle is;
    - ``ids``: (H, W) uint32, the face each pixel shows (the mesh's faces in order from 0;
      4294967295 where none);
    - ``stats``: what the frame did (clipped, culled, rasterised, pixels covered, the kernels'
      tiles), as ``tileraster render --stats`` prints it;
    - ``checksums``: CRC-32 of each layer's bytes (``zlib.crc32``), as ``--stats`` prints them.
    """

    NO_FACE = 0xFFFF_FFFF

    def __init__(self, native):
        width, height, colour, depth, ids, stats, checksums = native
        self.width, self.height = width, height
        # The RGBA words' bytes in memory are R, G, B, A on a little-endian machine.
        assert sys.byteorder == "little", "frames are RGBA words: a little-endian machine reads them as bytes"
        self.colour = colour.view(np.uint8).reshape(height, width, 4)
        self.depth = depth.reshape(height, width)
        self.ids = ids.reshape(height, width)
        self.stats = json.loads(stats)
        self.checksums = json.loads(checksums)

    def __repr__(self) -> str:
        return f"tileraster.Frame({self.width}×{self.height}, {self.stats['pixels_covered']} pixels covered)"


def _mesh_source(mesh):
    """A path-like, or a ``Mesh``, or ``(positions, triangles)`` arrays."""
    if isinstance(mesh, Mesh) or isinstance(mesh, (str, os.PathLike)):
        return mesh
    if isinstance(mesh, tuple) and len(mesh) == 2:
        return Mesh(*mesh)
    raise TypeError(f"mesh: give a file's path, a tileraster.Mesh or (positions, triangles) arrays, not {type(mesh).__name__}")


def _matrices(instances):
    return None if instances is None else np.asarray(instances, dtype=np.float64).reshape(-1, 4, 4).tolist()


def _view(options) -> View:
    """The native view, numbers given as any array-like made plain lists."""
    for name, shape in (("mvp", (4, 4)), ("camera", (3, 3))):
        if options.get(name) is not None:
            options = dict(options, **{name: np.asarray(options[name], dtype=np.float64).reshape(shape).tolist()})
    return View(**options)


def render(mesh, *, time: float | None = None, z_scale: float = 1.0, instances=None, **options) -> Frame:
    """One frame of ``mesh``: a file's path (glTF, OBJ, PLY, STL, points as their TIN, a GeoTIFF
    DEM as terrain), a ``Mesh`` or ``(positions, triangles)`` arrays. ``time`` poses a glTF
    file's first animation; ``z_scale`` scales heights about the lowest point; ``instances``
    places the mesh once per (4, 4) affine matrix.
    """
    view = _view(options)
    return Frame(_render(_mesh_source(mesh), view, time=time, z_scale=float(z_scale), instances=_matrices(instances)))


render.__doc__ += _VIEW_OPTIONS


class Renderer:
    """One mesh kept for many frames: read, posed and prepared once; each ``render(...)`` costs
    only the frame's own stages, without the GIL, and gives ``tileraster.render``'s bits for
    the same arguments (instances are drawn as one mesh: the same pixels, one instance in the
    stats). ``points=True`` keeps a DEM's vertices so that frames may draw them.

    ::

        renderer = tileraster.Renderer("helmet.glb")
        for k in range(36):
            a = np.radians(10 * k)
            frame = renderer.render(size=(512, 512), camera=((3 * np.cos(a), 0, 3 * np.sin(a)), (0, 0, 0), (0, 1, 0)))
    """

    def __init__(self, mesh, *, time: float | None = None, z_scale: float = 1.0, instances=None, points: bool = False):
        self._native = _Renderer(_mesh_source(mesh), time=time, z_scale=float(z_scale), instances=_matrices(instances), points=points)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The lowest and highest corners (x, y, z) of the box holding what the frames draw
        (posed, scaled and placed), to aim cameras at."""
        lo, hi = self._native.bounds
        return np.array(lo), np.array(hi)

    def render(self, **options) -> Frame:
        return Frame(self._native.render(_view(options)))


Renderer.render.__doc__ = "One frame." + _VIEW_OPTIONS
