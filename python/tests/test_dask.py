"""tileraster.dask: a DEM's chunks computed apart, on threads or on a cluster of worker
processes, are the single run's cells bit for bit (the command line's, on the same files)."""

from __future__ import annotations

from pathlib import Path

import dask
import numpy as np
import pytest

import tileraster
import tileraster.dask
from test_tileraster import REPO, cli



def survey(n: int = 30_000, seed: int = 5) -> np.ndarray:
    """Points at UTM coordinates over 600 × 400 m: random ground, a lattice patch (cocircular
    fours), a round hole with no points and repeated positions with other heights."""
    rng = np.random.default_rng(seed)
    x, y = rng.uniform(0, 600, n).round(3), rng.uniform(0, 400, n).round(3)
    keep = np.hypot(x - 420, y - 250) > 45
    ground = np.column_stack([x[keep], y[keep], 100 + np.sin(x[keep] / 40) * 8 + y[keep] * 0.02])
    k = np.arange(40 * 25)
    lattice = np.column_stack([100 + (k % 40) * 2.0, 60 + (k // 40) * 2.0, (k % 13) * 1.0])
    points = np.vstack([ground, lattice])
    points = np.vstack([points, points[::53] + [0, 0, 3]])
    return points + [500_000, 5_000_000, 0]


def write_tiles(points: np.ndarray, directory: Path, nx: int = 3, ny: int = 2) -> None:
    """The points as CSV tiles of the survey, named so that their order is not the tiles'."""
    directory.mkdir()
    i = np.clip(((points[:, 0] - 500_000) // (600 / nx)).astype(int), 0, nx - 1)
    j = np.clip(((points[:, 1] - 5_000_000) // (400 / ny)).astype(int), 0, ny - 1)
    for t in range(nx * ny):
        mine = points[i + nx * j == t]
        np.savetxt(directory / f"tile-{(t * 7) % (nx * ny)}.csv", mine, delimiter=",", header="x,y,z", comments="", fmt="%.17g")


def read_tif(path: Path):
    import rasterio
    with rasterio.open(path) as f:
        return f.read(1), f.transform, f.nodata


def test_a_process_cluster_gives_the_command_lines_dem(tmp_path):
    from distributed import Client, LocalCluster, Lock
    write_tiles(survey(), tmp_path / "tiles")
    cli("rasterise", tmp_path / "tiles", "-o", tmp_path / "cli.tif", "--backend", "cpu", "--tr", "0.5", "0.5")
    expected, transform, _ = read_tif(tmp_path / "cli.tif")
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, Client(cluster) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        dem = tileraster.dask.points_to_dem([tmp_path / "tiles"], tileraster.Grid(tr=(0.5, 0.5)), chunks=(203, 317), crs="EPSG:32633")
        assert dem.shape == expected.shape and dem.data.numblocks == (4, 4)
        values = dem.values
        where = client.run(lambda: __import__("os").getpid())
        assert len(set(where.values())) == 2
        # Chunk by chunk, each written by the worker that computed it, one at a time.
        dem.rio.to_raster(tmp_path / "dask.tif", tiled=True, compress="DEFLATE", lock=Lock("dask.tif"))
    assert values.tobytes() == expected.tobytes(), f"{np.count_nonzero(values != expected)} cells differ from the single run"
    written, written_transform, nodata = read_tif(tmp_path / "dask.tif")
    assert written.tobytes() == expected.tobytes() and written_transform == transform and nodata == -9999
    # Cell centres, north to south.
    assert dem.x.values[0] == transform.c + 0.25 and dem.y.values[0] == transform.f - 0.25 and dem.y.values[1] < dem.y.values[0]


def test_a_real_lidar_tiles_ground_in_chunks_on_threads(tmp_path):
    laz = REPO / "tests" / "data" / "autzen_trim.laz"
    cli("rasterise", laz, "-o", tmp_path / "cli.tif", "--backend", "cpu", "--tr", "2", "2", "--class", "2", "--max-edge", "30")
    expected, _, _ = read_tif(tmp_path / "cli.tif")
    dem = tileraster.dask.points_to_dem(laz, tileraster.Grid(tr=(2, 2)), chunks=(300, 500), classes=[2], max_edge=30)
    with dask.config.set(scheduler="threads"):
        values = dem.values
    assert (values != -9999).sum() > values.size // 2
    assert values.tobytes() == expected.tobytes(), f"{np.count_nonzero(values != expected)} cells differ from the single run"


def test_a_copc_files_chunks_decode_their_nodes(tmp_path):
    copc = REPO / "tests" / "data" / "autzen_trim.copc.laz"
    cli("rasterise", copc, "-o", tmp_path / "cli.tif", "--backend", "cpu", "--tr", "2", "2", "--class", "2")
    expected, _, _ = read_tif(tmp_path / "cli.tif")
    dem = tileraster.dask.points_to_dem(copc, tileraster.Grid(tr=(2, 2)), chunks=(100, 200), classes=[2])
    with dask.config.set(scheduler="threads"):
        values = dem.values
    assert values.tobytes() == expected.tobytes(), f"{np.count_nonzero(values != expected)} cells differ from the single run"
    summary = tileraster._native.summarise_points(str(copc), classes=[2])
    grid = tileraster.Grid(tr=(2, 2)).resolve(summary[2])
    block = tileraster._native.block_dem([summary], grid, (250, 120, 50, 50), classes=[2]).block
    assert summary[5] == 110_000 and 0 < block["points_decoded"] < 110_000, block


def test_dask_arrays_and_dataframes_count_as_their_partitions_in_order(tmp_path):
    import dask.array as da
    import dask.dataframe as dd
    import pandas as pd
    points = survey(20_000, seed=3)
    grid = tileraster.Grid(tr=(1.0, 1.0))
    single = tileraster.points_to_dem(points, grid, backend="cpu").values
    dem = tileraster.dask.points_to_dem(da.from_array(points, chunks=(3_000, 3)), grid, chunks=(150, 250), spill=tmp_path / "array")
    # The grid's extent comes from the points: the partitions are written at the call.
    assert dem.data.numblocks == (3, 3) and len(list((tmp_path / "array").glob("*.npy"))) == 7, "a partition a file"
    with dask.config.set(scheduler="threads"):
        assert dem.values.tobytes() == single.tobytes()
    # A DataFrame in x order whose first partition the filter empties, computed in processes.
    ordered = points[np.argsort(points[:, 0], kind="stable")]
    frame = dd.from_pandas(pd.DataFrame(ordered, columns=["easting", "northing", "h"]), npartitions=5, sort=False)
    kept = frame[frame.easting > ordered[len(ordered) // 5 + 10, 0]]
    expected = tileraster.points_to_dem(kept.compute().to_numpy(), grid, backend="cpu").values
    dem = tileraster.dask.points_to_dem(kept, grid, chunks=(300, 300), columns=("easting", "northing", "h"), spill=tmp_path / "frame")
    with dask.config.set(scheduler="processes"):
        assert dem.values.tobytes() == expected.tobytes()
    with pytest.raises(tileraster.TilerasterError, match="missing"):
        tileraster.dask.points_to_dem(frame, grid, spill=tmp_path / "bad")
    with pytest.raises(tileraster.TilerasterError, match="shape"):
        tileraster.dask.points_to_dem(da.zeros((10, 2)), grid, spill=tmp_path / "bad")


def test_an_array_of_points_on_a_given_extent_is_lazy_and_exact():
    points = survey(8_000, seed=9)
    grid = tileraster.Grid(txe=(500_010.0, 500_590.0), tye=(5_000_005.0, 5_000_395.0), outsize=(580, 390))
    single = tileraster.points_to_dem(points, grid, backend="cpu")
    dem = tileraster.dask.points_to_dem(points, grid, chunks=(100, 150), nodata=-1)
    assert dem.data.numblocks == (4, 4) and dem.attrs["_FillValue"] == -1
    with dask.config.set(scheduler="sync"):
        part = dem[150:260, 140:400].values
        whole = dem.values
    expected = np.where(single.values == -9999, np.float32(-1), single.values)
    assert whole.tobytes() == expected.tobytes() and part.tobytes() == expected[150:260, 140:400].tobytes()


def test_bad_arguments_and_changed_files_raise_the_librarys_errors(tmp_path):
    grid = tileraster.Grid(tr=(1, 1))
    with pytest.raises(tileraster.TilerasterError, match="chunks"):
        tileraster.dask.points_to_dem(survey(100), grid, chunks=(0, 10))
    with pytest.raises(tileraster.TilerasterError, match="No such file"):
        tileraster.dask.points_to_dem([tmp_path / "none.laz"], grid)
    with pytest.raises(tileraster.TilerasterError, match="classes"):
        tileraster.dask.points_to_dem(survey(100), grid, classes=[2])
    write_tiles(survey(3_000), tmp_path / "tiles")
    dem = tileraster.dask.points_to_dem(tmp_path / "tiles", grid, chunks=(100, 100))
    # A tile rewritten after the summaries were taken: refused, never read as if unchanged.
    (tmp_path / "tiles" / "tile-0.csv").write_text("x,y,z\n500100,5000100,1\n")
    with pytest.raises(tileraster.TilerasterError, match="changed"), dask.config.set(scheduler="sync"):
        dem.compute()
