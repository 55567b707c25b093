"""tileraster: deterministic rasterisation of TINs and point clouds to DEMs, and of meshes to
frames.

The same cells, bit for bit, on the CPU backend and on any Vulkan GPU, with gdal_grid's grid
semantics. Arrays come in as numpy arrays and go out as numpy arrays::

    import numpy as np, tileraster
    grid = tileraster.Grid(tr=(1.0, 1.0))                 # the points' extent, 1 m cells
    dem = tileraster.points_to_dem(points, grid)          # points: (N, 3) x, y, z
    dem.values                                            # float32, (rows, columns), row 0 north
    dem.transform                                         # rasterio's Affine(*dem.transform)
    dem.write("dem.tif", epsg=32633)                      # the command line's GeoTIFF

Errors raise ``TilerasterError`` (a ``ValueError``) with the library's message, and Ctrl-C
stops a long call with ``KeyboardInterrupt``. ``tileraster.dask.points_to_dem`` makes DEMs
of many point files as lazy ``xarray`` arrays whose chunks Dask computes apart, with the
single run's cells.

``render`` draws a mesh (a file, or numpy arrays as a ``Mesh``) as ``tileraster render`` does,
the same bytes for the same options: ``frame.colour`` (H, W, 4) uint8, ``frame.depth``,
``frame.ids`` (the face each pixel shows); ``Renderer`` keeps a mesh for many frames.
"""

from __future__ import annotations

import os
import tempfile

from ._native import Grid, Prepared, Raster, Scene, TilerasterError, backends
from ._native import rasterise as _rasterise
from ._render import Frame, Mesh, Renderer, render


def _give_vulkan_a_runtime_dir() -> None:
    """Mesa's Vulkan drivers print ``error: XDG_RUNTIME_DIR is invalid or not set`` when the
    process has none (a container, a batch job, ssh without a login session), though nothing
    fails. As the command line does, give the process a private runtime directory of its own,
    as a login session would, where it has no valid one: before any Vulkan driver is loaded."""
    valid = lambda d: os.path.isdir(d) and os.stat(d).st_uid == os.getuid()  # noqa: E731
    current = os.environ.get("XDG_RUNTIME_DIR")
    if current and valid(current):
        return
    private = os.path.join(tempfile.gettempdir(), f"tileraster-runtime-{os.getuid()}")
    try:
        os.makedirs(private, mode=0o700, exist_ok=True)
    except OSError:
        return
    if valid(private):
        os.environ["XDG_RUNTIME_DIR"] = private


_give_vulkan_a_runtime_dir()

__all__ = ["Frame", "Grid", "Mesh", "Prepared", "Raster", "Renderer", "Scene", "TilerasterError", "backends", "points_to_dem", "rasterise", "render",
           "tin"]


def tin(points, *, max_edge: float | None = None) -> Scene:
    """The Delaunay TIN of ``points`` ((N, 3) x, y, z), as the command line builds it: of points
    with equal x, y the first is kept. ``max_edge`` leaves out triangles with an edge longer
    than that (map units, in x and y), so gaps stay nodata. Its ``triangles`` are what owner
    rasters index."""
    scene = Scene.from_points(points)
    return scene if max_edge is None else scene.without_long_edges(max_edge)


def rasterise(vertices, triangles, grid: Grid, *, backend: str = "auto", mode: str = "exact", nodata: float = -9999.0,
              owner: bool = False, window: tuple[int, int, int, int] | None = None) -> Raster:
    """Rasterise a mesh ((N, 3) vertices, (M, 3) triangles; or a ``Scene`` as ``vertices``
    with ``triangles=None``) onto ``grid``.

    - ``backend``: ``"cpu"``, ``"gpu"`` (a Vulkan adapter; lavapipe counts) or ``"auto"`` (a
      hardware GPU if there is one and the grid has at least 1024² cells, else the CPU; decided
      without opening a device, from a survey of the adapters cached under
      ``~/.cache/tileraster``). Both give the same bits.
    - ``mode``: ``"exact"`` (correctly rounded), ``"plane-f32"`` or ``"barycentric"``.
    - ``owner=True`` also returns ``Raster.owner``: the index of the triangle each cell's value
      comes from (uint32; 4294967295 where none).
    - ``window=(x0, y0, width, height)``: only that window of the grid, its cells bit for bit
      the whole grid's there.
    """
    scene = vertices if isinstance(vertices, Scene) and triangles is None else Scene(vertices, triangles)
    return _rasterise(scene, grid, backend=backend, mode=mode, nodata=float(nodata), owner=owner, window=window)


def points_to_dem(points, grid: Grid, *, backend: str = "auto", mode: str = "exact", nodata: float = -9999.0,
                  owner: bool = False, window: tuple[int, int, int, int] | None = None,
                  max_edge: float | None = None, radius: float = 0.0) -> Raster:
    """A DEM from points ((N, 3) x, y, z): their Delaunay TIN (see ``tin``) rasterised onto
    ``grid``, as ``tileraster rasterise points.laz`` makes it. Filter classes with numpy
    first (``xyz[las.classification == 2]``). Arguments as ``rasterise``, and:

    - ``max_edge``: the command line's ``--max-edge``;
    - ``radius``: gdal_grid's ``linear:radius``: cells outside every triangle take the z of the
      nearest point within ``radius`` as gdal_grid 3.6 picks it (negative: any distance;
      0, the default: they stay nodata).
    """
    return _rasterise(tin(points, max_edge=max_edge), grid, backend=backend, mode=mode, nodata=float(nodata), owner=owner,
                      window=window, points=points, radius=float(radius))
