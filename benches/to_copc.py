#!/usr/bin/env python3
"""Write LAS/LAZ files as COPC (cloud-optimised point clouds), for tests and benchmarks.

    python benches/to_copc.py IN.laz [IN2.laz ...] --out DIR [--node-points 20000] [--seed 1]

Each input becomes DIR/NAME.copc.laz with the same points (point format 6: the same scale and
offset, so the same coordinates, classifications and returns; colours and waveforms are left
out): an octree over the points' cube whose root holds a random sample of `--node-points`
points, each further level four times as many, spread over its cubes, and the deepest level
the rest, as COPC writers lay levels out. Nodes are written in key order, each node's points
in the input's order. Needs laspy, lazrs, numpy and copclib (`pip install laspy lazrs numpy
copclib`).
"""

import argparse
import pathlib

import copclib
import laspy
import numpy as np


def levels_of(n: int, node_points: int, rng: np.random.Generator) -> np.ndarray:
    """Each point's octree level: a random order, the first `node_points` at level 0, the next
    4 times as many at level 1, and so on; the deepest level takes the rest."""
    rank = np.empty(n, dtype=np.int64)
    rank[rng.permutation(n)] = np.arange(n)
    level = np.zeros(n, dtype=np.int32)
    start, size, depth = node_points, node_points * 4, 1
    while start < n:
        level[rank >= start] = depth
        start, size, depth = start + size, size * 4, depth + 1
    return level


def convert(source: pathlib.Path, target: pathlib.Path, node_points: int, seed: int) -> int:
    las = laspy.read(source)
    fmt = 6
    if las.header.point_format.id != fmt:
        las = laspy.convert(las, point_format_id=fmt)
    scale, offset = las.header.scales, las.header.offsets
    x, y, z = np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)
    lo = np.array([x.min(), y.min(), z.min()])
    hi = np.array([x.max(), y.max(), z.max()])
    centre = (lo + hi) / 2
    halfsize = float((hi - lo).max() / 2) * (1 + 1e-9) + float(scale.max())
    level = levels_of(len(x), node_points, np.random.default_rng(seed))
    side = 2 * halfsize / (2.0 ** level)
    keys = [np.clip(np.floor((v - (c - halfsize)) / side), 0, 2.0 ** level - 1).astype(np.int64) for v, c in zip((x, y, z), centre)]
    config = copclib.CopcConfigWriter(
        fmt,
        copclib.Vector3(*map(float, scale)),
        copclib.Vector3(*map(float, offset)),
    )
    config.copc_info.center_x, config.copc_info.center_y, config.copc_info.center_z = map(float, centre)
    config.copc_info.halfsize = halfsize
    config.copc_info.spacing = 2 * halfsize / np.sqrt(node_points)
    config.las_header.min = copclib.Vector3(*map(float, lo))
    config.las_header.max = copclib.Vector3(*map(float, hi))
    target.parent.mkdir(parents=True, exist_ok=True)
    writer = copclib.FileWriter(str(target), config)
    records = las.points.array
    # Nodes in key order (level, x, y, z); each node's points in the input's order.
    order = np.lexsort((np.arange(len(x)), keys[2], keys[1], keys[0], level))
    table = np.stack([level, keys[0], keys[1], keys[2]], axis=1)[order]
    cuts = np.flatnonzero(np.any(table[1:] != table[:-1], axis=1)) + 1
    for part in np.split(order, cuts):
        d, i, j, k = (int(v) for v in (level[part[0]], keys[0][part[0]], keys[1][part[0]], keys[2][part[0]]))
        data = np.frombuffer(records[part].tobytes(), dtype=np.int8)
        writer.AddNode(copclib.VoxelKey(d, i, j, k), copclib.VectorChar(data))
    writer.Close()
    return len(x)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("inputs", nargs="+", type=pathlib.Path)
    parser.add_argument("--out", type=pathlib.Path, required=True)
    parser.add_argument("--node-points", type=int, default=20000)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    for source in args.inputs:
        name = source.name.split(".")[0] + ".copc.laz"
        n = convert(source, args.out / name, args.node_points, args.seed)
        print(f"{args.out / name}: {n} points")


if __name__ == "__main__":
    main()
