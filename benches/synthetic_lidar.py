"""A synthetic airborne LiDAR collection: square LAZ tiles of realistic terrain at UTM
coordinates, for the DEM-at-scale benchmarks (docs/benchmarks.md).

    python benches/synthetic_lidar.py OUT_DIR --tiles 10 --tile-size 1000 --density 1.0

Terrain: rolling hills and a valley from a few octaves of smooth noise; ground points
(class 2) at the given density, random in x and y (no two at one position), vegetation
(class 5) above a fifth of them; a lake with no points; in every fourth tile a patch of
points on an exact square lattice (the cocircular fours that Delaunay ties are made of), as
gridded or resampled data gives. Deterministic for a seed. Needs numpy, laspy and lazrs.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import laspy
import numpy as np

EAST, NORTH = 500_000.0, 5_000_000.0


def height(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Smooth terrain in metres: octaves of sines at incommensurate wavelengths, and a valley."""
    z = 200.0 + 0.01 * x - 0.005 * y
    for k, (wave, amp) in enumerate([(1900.0, 30.0), (730.0, 12.0), (260.0, 4.0), (90.0, 1.2), (31.0, 0.3)]):
        phase = 1.7 * k
        z += amp * np.sin(x / wave + phase) * np.cos(y / (wave * 1.3) - phase)
    return z - 25.0 * np.exp(-(((x - y * 0.4) % 3000.0 - 1500.0) / 180.0) ** 2)


def tile(i: int, j: int, size: float, density: float, seed: int, side: float) -> laspy.LasData:
    rng = np.random.default_rng([seed, i, j])
    n = rng.poisson(density * size * size)
    x0, y0 = i * size, j * size
    # Centimetre positions, each at most once, like a scanner's after duplicate removal.
    cells = int(size * 100)
    flat = np.unique(rng.integers(0, cells * cells, n))
    rng.shuffle(flat)
    x, y = x0 + (flat % cells) / 100.0, y0 + (flat // cells) / 100.0
    lake = np.hypot(x - 0.37 * side, y - 0.61 * side) > 0.08 * side
    x, y = x[lake], y[lake]
    z = height(x, y) + rng.normal(0.0, 0.03, x.size)
    cls = np.full(x.size, 2, np.uint8)
    if (i + 2 * j) % 4 == 0:
        # An exact 0.5 m lattice patch of 80 × 80 points at the tile's centre.
        k = np.arange(80 * 80)
        lx, ly = x0 + size / 2 + (k % 80) * 0.5, y0 + size / 2 + (k // 80) * 0.5
        away = (np.abs(x - x0 - size / 2 - 20) > 21) | (np.abs(y - y0 - size / 2 - 20) > 21)
        x, y, z, cls = x[away], y[away], z[away], cls[away]
        x, y = np.concatenate([x, lx]), np.concatenate([y, ly])
        z, cls = np.concatenate([z, height(lx, ly)]), np.concatenate([cls, np.full(lx.size, 2, np.uint8)])
    vegetation = rng.random(x.size) < 0.2
    z = np.where(vegetation, z + rng.uniform(2.0, 25.0, x.size), z)
    cls = np.where(vegetation, np.uint8(5), cls)
    header = laspy.LasHeader(point_format=1, version="1.2")
    header.scales = [0.01, 0.01, 0.01]
    header.offsets = [EAST, NORTH, 0.0]
    las = laspy.LasData(header)
    las.x, las.y, las.z = EAST + x, NORTH + y, z
    las.classification = cls
    return las


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("out", type=Path)
    parser.add_argument("--tiles", type=int, default=10, help="tiles along each side (default 10)")
    parser.add_argument("--tile-size", type=float, default=1000.0, help="metres (default 1000)")
    parser.add_argument("--density", type=float, default=1.0, help="points per square metre (default 1)")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    total = 0
    for j in range(args.tiles):
        for i in range(args.tiles):
            las = tile(i, j, args.tile_size, args.density, args.seed, args.tiles * args.tile_size)
            las.write(args.out / f"tile_{i:03d}_{j:03d}.laz", laz_backend=laspy.LazBackend.Lazrs)
            total += len(las.points)
    print(f"{args.tiles * args.tiles} tiles, {total} points in {args.out}")


if __name__ == "__main__":
    main()
