"""The shapes of the dicts haustra returns, as TypedDicts (for editors and type checkers).

At run time they are plain dicts; python/tests/test_types.py checks that every key listed here is
what the module returns, and nothing else.
"""

from typing import Dict, Optional, TypedDict

import numpy
import numpy.typing

Vector3 = numpy.typing.NDArray[numpy.float64]  # shape (3,)


class Profile(TypedDict):
    """World.profile: the last frame, stage by stage (docs/architecture.md names the stages)."""
    seconds: Dict[str, float]  # wall time per stage, s
    calls: Dict[str, int]  # times each stage ran
    frame_seconds: float  # the whole frame, s
    substeps: int  # substeps the frame was split into
    iterations: int  # fixed-point iterations run, summed over substeps
    retries: int  # frames redone by the robust mode
    fallbacks: int  # Newton iterations solved by the banded LU
    backtracks: int  # line-search halvings
    stiffenings: int  # Newton steps solved again with stiffened law rows
    chords: int  # fast mode: Newton iterations that reused the last factorization
    stalls: int  # line searches that took no part of a step that was not small
    late: int  # 1 when the frame took longer than world.frame_budget
    nodes_asleep: int  # nodes of rods and ranges that slept through the frame (decisions 0119, 0127)
    newton: bool  # the frame that was kept ran Newton iterations


class Instrument(TypedDict):
    """World.instrument(i): an instrument after the last frame; forces are the tissue's on it."""
    tip: Vector3  # m: where the capsule is (a proxy's: where its coupling and contacts balance)
    commanded_tip: Vector3  # m: where it is commanded (set_instrument_pose or its keyframes)
    axis: Vector3  # unit
    closed: bool  # jaws closed
    cutting: bool  # cuts the connective tissue within its cut radius
    grasping: bool  # holding a node
    grasped_segment: Optional[int]  # None when not grasping
    grasped_node: Optional[int]  # local to the segment; None when not grasping
    slipped: bool  # closed, but its grasp let go (pulled past its holding force)
    grasp_target: Vector3  # m: where the grasp wants the node
    force: Vector3  # N
    torque: Vector3  # N·m, about the tip
    filtered_force: Vector3  # N, low-passed
    filtered_torque: Vector3  # N·m, low-passed


class ContactSummary(TypedDict):
    """World.contacts: the last frame's contacts in summary (contact_records has each one)."""
    candidates: int  # pairs and bead-shape pairs within the margin at the frame's start
    touching: int  # of those, overlapping at its end
    max_environment_depth: float  # m: deepest bead into a plane, obstacle, mesh or instrument
    max_environment_depth_ratio: float  # the same over that bead's radius
    max_bead_overlap: float  # m: deepest overlap of two beads that may collide
    max_bead_overlap_ratio: float  # the same over the smaller radius


class Energy(TypedDict):
    """World.energy, J."""
    elastic: float
    gravity: float
    tissue: float  # what the connective tissue's intact anchors store
    total: float


class Segment(TypedDict):
    """One entry of World.segments: where a segment's nodes, beads and mesh are in the arrays."""
    name: str
    node_offset: int
    node_count: int
    chain: int  # the first segment of its chain (itself when not chained)
    length: float  # m, at rest
    bending_stiffness: float  # N·m²
    torsion_stiffness: float  # N·m²
    axial_stiffness: float  # N
    linear_density: float  # kg/m
    bead_offset: int
    bead_count: int
    mesh_vertex_offset: int
    mesh_vertex_count: int
    mesh_triangle_offset: int
    mesh_triangle_count: int


class Event(TypedDict):
    """One entry of World.events: a recovery, an instability, a slip, anchors torn or cut."""
    kind: str
    frame: int
    segment: int
    node: int
    stage: str
    substeps: int
    message: str


class MemoryEstimate(TypedDict):
    """haustra.estimate_memory: bytes and seconds a scene would take, before it is built (the numbers of
    `haustra estimate`, the C API's haustra_estimate_scene and World::create's refusal)."""
    total: int
    nodes: int  # rod nodes (a count)
    rod_bytes: int
    solver_bytes: int
    bead_bytes: int
    mesh_bytes: int
    beads: int  # a count
    bead_pairs: int  # pairs of one segment's beads within reach of each other at rest (a count)
    pair_bytes: int
    build_seconds: float  # on one core of the reference machine
    step_seconds: float  # a frame at rest, on one core of the reference machine
    available: int  # what this machine has available


class ValidationCase(TypedDict):
    """One entry of haustra.validate(): a reference case against its analytic or published value."""
    name: str
    quantity: str
    reference: float
    value: float
    error: float
    tolerance: float
    absolute: bool
    passed: bool
    note: str
