#!/usr/bin/env python3
"""Runs a scene to a frame and writes its organ mesh there through the engine's writers.

    PYTHONPATH=build/release/python python3 python/examples/export_frame.py --frame 120 --out out/python/frame.ply
"""
import argparse
import pathlib

import haustra

ROOT = pathlib.Path(__file__).resolve().parents[2]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default=str(ROOT / "scenes" / "demo.toml"))
    parser.add_argument("--frame", type=int, default=120)
    parser.add_argument("--segment", type=int, default=0)
    parser.add_argument("--out", default="out/python/frame.ply", help=".obj, .ply, .stl or .glb")
    args = parser.parse_args()
    w = haustra.World.from_scene(args.scene)
    w.step(args.frame)
    pathlib.Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    haustra.save_segment_mesh(w, args.out, args.segment)
    info = w.segments[args.segment]
    print(f"wrote {args.out}: segment '{info['name']}' at frame {w.frame}, "
          f"{info['mesh_vertex_count']} vertices, {info['mesh_triangle_count']} triangles")


if __name__ == "__main__":
    main()
