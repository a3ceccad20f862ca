"""haustra: long, very flexible soft organs (rectum, colon, small intestine) in real time.

A Cosserat rod along the organ's centreline deforms; rigid beads on it collide; a cage built
from the beads drives the organ mesh through mean value coordinates (Chang et al. 2011).

    import haustra
    world = haustra.World.from_scene("scenes/demo.toml", overrides={"segment.nodes": 121})
    p = world.node_positions        # (N, 3) float64, no copy
    world.step(60)                  # p now shows frame 60: the view is live
    print(p[-1], world.profile["frame_seconds"])

Views (node_positions, strains, bead_centres, mesh_positions, mesh_normals, ...) are read-only
NumPy arrays over the engine's own buffers. The engine updates those buffers in place, so a view
shows the state after the last completed step; read it between steps (a step on another thread
is writing it). A view keeps its memory alive: after the world is deleted, or after
add_segment / remove_segment moved the world to new buffers, it stays valid memory holding the
values of the last step before that (it is no longer updated). Copy (`numpy.array(view)`) what
you want to keep from a frame.

Errors raise haustra.Error (or a subclass per kind: InvalidArgumentError, FileError, ParseError,
GeometryError, UnstableError, InternalError, BusyError) with the engine's message: file, line and field. An
index argument out of range raises InvalidIndexError, both an InvalidArgumentError and an IndexError;
negative indices count from the end, as in Python.
"""

import os

from ._haustra import (  # noqa: F401
    __version__,
    CONTACT_KINDS,
    RECORDABLE,
    BusyError,
    Error,
    FileError,
    GeometryError,
    InternalError,
    InvalidArgumentError,
    InvalidIndexError,
    ParseError,
    UnstableError,
    Batch,
    World,
    estimate_memory,
    save_mesh,
    validate,
)

__all__ = [
    "__version__", "World", "Batch", "validate", "save_mesh", "estimate_memory", "Error", "InvalidArgumentError",
    "FileError", "InvalidIndexError", "ParseError", "GeometryError", "UnstableError", "InternalError", "BusyError",
    "save_segment_mesh", "RECORDABLE",
    "CONTACT_KINDS",
]


def save_segment_mesh(world: World, path: "str | os.PathLike[str]", segment: int = 0) -> None:
    """Writes one segment's organ mesh at the current frame (.obj, .ply, .stl, .glb), with normals."""
    info = world.segments[segment]
    first, count = info["mesh_vertex_offset"], info["mesh_vertex_count"]
    if count == 0:
        raise InvalidArgumentError(f"segment {segment} ('{info['name']}') has no organ mesh")
    t0, tn = info["mesh_triangle_offset"], info["mesh_triangle_count"]
    triangles = world.mesh_triangles[t0:t0 + tn].astype("int64") - first  # global indices to the segment's own
    save_mesh(path, world.mesh_positions[first:first + count], triangles, world.mesh_normals[first:first + count])
