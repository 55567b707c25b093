"""What each lit shading costs a frame: the 100,352-triangle terrain of `viewer_fps.py`, filling
the frame, drawn by a prepared `tileraster.Renderer` in every shading named, the shadings taken
in turn within each round (so that the machine's load falls on all alike), medians of the
rounds.

    python benches/shading_cost.py [--size 1920 1080] [--rounds 15] [--backend cpu] [--shadings smooth phong pbr]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import tileraster
from viewer_fps import terrain_obj


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--size", type=int, nargs=2, default=[1920, 1080])
    parser.add_argument("--rounds", type=int, default=15)
    parser.add_argument("--backend", default="cpu")
    parser.add_argument("--shadings", nargs="+", default=["unlit", "smooth", "phong", "pbr"])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as d:
        mesh = Path(d) / "terrain.obj"
        triangles = terrain_obj(mesh, 225)
        renderer = tileraster.Renderer(mesh)
        camera = ((1000, 600, 900), (1000, 600, 80), (0, 1, 0))
        times: dict[str, list[float]] = {s: [] for s in args.shadings}
        for _ in range(args.rounds + 1):
            for shading in args.shadings:
                start = time.perf_counter()
                renderer.render(size=tuple(args.size), camera=camera, shading=shading, backend=args.backend)
                times[shading].append(time.perf_counter() - start)
        print(f"{triangles} triangles, {args.size[0]}×{args.size[1]}, {args.backend} backend, medians of {args.rounds} rounds (the first dropped):")
        base = statistics.median(times[args.shadings[0]][1:])
        for shading, t in times.items():
            median = statistics.median(t[1:])
            print(f"  {shading:8} {median * 1e3:7.1f} ms  ({median / base:.2f}× {args.shadings[0]})")


if __name__ == "__main__":
    main()
