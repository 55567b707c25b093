"""DEMs larger than one machine: a lazy ``xarray.DataArray`` whose chunks Dask computes apart.

Each chunk triangulates only the points around it and proves its triangles are the whole
point set's there, so the chunks' cells are the single run's bit for bit, on any scheduler
(threads, processes, a ``distributed`` cluster of many machines)::

    import tileraster, tileraster.dask
    grid = tileraster.Grid(tr=(1.0, 1.0))
    dem = tileraster.dask.points_to_dem(["tiles/*.laz"], grid, chunks=(4096, 4096), classes=[2], crs="EPSG:32633")
    dem.rio.to_raster("dem.tif", tiled=True, compress="DEFLATE")   # or dem.compute(), dem[1000:2000, :]

Needs ``dask[array]`` and ``xarray`` (``rioxarray`` for ``crs`` and ``.rio``).
"""

from __future__ import annotations

import os
from typing import Sequence

import numpy as np

from . import Grid, TilerasterError
from . import _native

__all__ = ["points_to_dem"]


def points_to_dem(inputs, grid: Grid, *, chunks: tuple[int, int] = (4096, 4096), nodata: float = -9999.0, backend: str = "cpu",
                  mode: str = "exact", max_edge: float | None = None, classes: Sequence[int] | None = None, crs=None,
                  name: str = "dem", columns: Sequence[str] = ("x", "y", "z"), spill=None):
    """A DEM of the points' Delaunay TIN on ``grid``, as a lazy ``xarray.DataArray`` (dims
    ``y``, ``x``; coordinates at cell centres, ``y`` north to south) in chunks of
    ``chunks=(rows, columns)`` cells.

    - ``inputs``: point files (LAS, LAZ, COPC, delimited text, ``.npy``), directories and glob
      patterns, as the command line takes them, in the order their points count as one file's;
      an (N, 3) numpy array of x, y, z; or a Dask array of shape (N, 3) or a Dask DataFrame
      with the ``columns`` x, y, z, whose partitions count in their order.
    - Files are read twice: once, one task a file, for each file's point count, bounds and
      convex hull (at this call when the grid's extent comes from the points, else lazily);
      then by each chunk, only the files its region meets (a COPC file's octree nodes).
    - A Dask array's or DataFrame's partitions are each computed once and written, exactly,
      as a ``.npy`` file in the directory ``spill`` (default: a temporary directory removed
      when the interpreter exits; on a cluster of several machines, give one they all share),
      then read as files are.
    - ``nodata``, ``backend``, ``mode``, ``max_edge``: as ``tileraster.points_to_dem``;
      ``classes``: LAS classifications to keep (``[2]``: ground), as ``--class``.
    - ``crs``: the points' CRS (anything rioxarray takes, e.g. ``"EPSG:32633"``): written with
      the transform and nodata for ``.rio``.

    A chunk's errors (a file that changed since its summary, a triangle too wide for the
    snapping lattice every chunk shares) raise ``TilerasterError`` when it is computed.
    """
    import dask
    import dask.array as da
    import xarray as xr

    chunk_rows, chunk_columns = (int(c) for c in chunks)
    if chunk_rows < 1 or chunk_columns < 1:
        raise TilerasterError(f"chunks={chunks!r}: give (rows, columns), both at least 1")
    nodata = float(nodata)
    classes = [int(c) for c in classes or []]
    options = dict(backend=backend, mode=mode, nodata=nodata, max_edge=None if max_edge is None else float(max_edge))
    if isinstance(inputs, np.ndarray):
        if classes:
            raise TilerasterError("classes filters LAS files; filter an array with numpy first")
        points = np.ascontiguousarray(inputs, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 3:
            raise TilerasterError(f"points has shape {points.shape}; give an (N, 3) array")
        bounds = (points[:, 0].min(), points[:, 1].min(), points[:, 0].max(), points[:, 1].max()) if len(points) else None
        source = dask.delayed(points, name=f"tileraster-points-{dask.base.tokenize(points)}")
        block = _block_of_points
    else:
        if _is_collection(inputs):
            if classes:
                raise TilerasterError("classes filters LAS files; filter a Dask collection first")
            files = _spilled(inputs, columns, spill)
        else:
            paths = [os.fspath(p) for p in ([inputs] if isinstance(inputs, (str, os.PathLike)) else inputs)]
            files = [str(f) for f in _native.input_files(paths)]
        summaries = [dask.delayed(_summarise, pure=True)(f, classes) for f in files]
        if not grid.extent_given:
            summaries = list(dask.compute(*summaries))
            boxes = [s[2] for s in summaries if s is not None and s[2] is not None]
            bounds = (min(b[0] for b in boxes), min(b[1] for b in boxes), max(b[2] for b in boxes), max(b[3] for b in boxes)) if boxes else None
        else:
            bounds = None
        source = dask.delayed(tuple, pure=True)(summaries)
        options["classes"] = classes
        block = _block_of_files
    grid_tuple = grid.resolve(bounds)
    xmin, xmax, ymin, ymax, width, height = grid_tuple
    blocks = []
    for y0 in range(0, height, chunk_rows):
        row = []
        for x0 in range(0, width, chunk_columns):
            window = (x0, y0, min(chunk_columns, width - x0), min(chunk_rows, height - y0))
            task = dask.delayed(block, pure=True)(source, grid_tuple, window, options)
            row.append(da.from_delayed(task, shape=(window[3], window[2]), dtype=np.float32))
        blocks.append(row)
    data = da.block(blocks)
    dx, dy = (xmax - xmin) / width, (ymax - ymin) / height
    coords = {"y": ymax - (np.arange(height) + 0.5) * dy, "x": xmin + (np.arange(width) + 0.5) * dx}
    dem = xr.DataArray(data, dims=("y", "x"), coords=coords, name=name, attrs={"_FillValue": np.float32(nodata)})
    if crs is not None:
        import rioxarray  # noqa: F401  (registers .rio)
        from affine import Affine

        dem = dem.rio.write_crs(crs).rio.write_transform(Affine(dx, 0.0, xmin, 0.0, -dy, ymax)).rio.write_nodata(np.float32(nodata))
    return dem


def _is_collection(inputs) -> bool:
    """Whether ``inputs`` is a Dask array or DataFrame (duck-typed: no import needed)."""
    return hasattr(inputs, "to_delayed") and hasattr(inputs, "dask")


_SPILLS: list[str] = []


def _remove_spills() -> None:
    import shutil

    for directory in _SPILLS:
        shutil.rmtree(directory, ignore_errors=True)


def _spilled(collection, columns: Sequence[str], spill) -> list:
    """Delayed paths of the ``.npy`` files that ``collection``'s partitions are written to, in
    order (``None`` for an empty partition)."""
    import atexit
    import tempfile

    import dask

    if hasattr(collection, "columns"):
        missing = [c for c in columns if c not in collection.columns]
        if len(columns) != 3 or missing:
            raise TilerasterError(f"the DataFrame has columns {list(collection.columns)}; give columns=(x, y, z) among them (missing: {missing})")
        parts = collection[list(columns)].to_delayed()
    else:
        if collection.ndim != 2 or collection.shape[1] != 3:
            raise TilerasterError(f"the Dask array has shape {collection.shape}; give an (N, 3) array of x, y, z")
        parts = list(collection.rechunk({1: -1}).to_delayed()[:, 0])
    if spill is None:
        if not _SPILLS:
            atexit.register(_remove_spills)
        spill = tempfile.mkdtemp(prefix="tileraster-spill-")
        _SPILLS.append(spill)
    os.makedirs(spill, exist_ok=True)
    token = dask.base.tokenize(collection, tuple(columns))
    return [dask.delayed(_spill, pure=True)(part, os.path.join(os.fspath(spill), f"{token}-{k:06d}.npy")) for k, part in enumerate(parts)]


def _spill(part, path: str):
    """Write one partition's points as ``path`` (whole or not at all); ``None`` when empty."""
    points = np.ascontiguousarray(part.to_numpy(dtype=np.float64) if hasattr(part, "to_numpy") else part, dtype=np.float64)
    if len(points) == 0:
        return None
    partial = path + ".partial"
    with open(partial, "wb") as f:
        np.save(f, points)
    os.replace(partial, path)
    return path


def _summarise(path, classes: list[int]):
    return None if path is None else _native.summarise_points(path, classes=classes)


def _block_of_files(summaries, grid, window, options):
    return _native.block_dem([s for s in summaries if s is not None], grid, window, **options).values


def _block_of_points(points, grid, window, options):
    return _native.block_dem_points(points, grid, window, **options).values
