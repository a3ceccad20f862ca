#!/usr/bin/env python3
"""Writes scenes/assets/bolster.obj: a closed cylinder (a horizontal bolster, the axis along y)
used as a static mesh obstacle. Outward-facing triangles; deterministic output."""
import math
import pathlib

radius, half_length, sides = 0.06, 0.4, 32
verts, faces = [], []
for end, y in enumerate((-half_length, half_length)):
    for i in range(sides):
        a = 2.0 * math.pi * i / sides
        verts.append((radius * math.cos(a), y, radius * math.sin(a)))
verts.append((0.0, -half_length, 0.0))  # cap centres
verts.append((0.0, half_length, 0.0))
c0, c1 = 2 * sides + 1, 2 * sides + 2  # 1-based indices in OBJ
for i in range(sides):
    j = (i + 1) % sides
    a0, a1, b0, b1 = i + 1, j + 1, sides + i + 1, sides + j + 1
    faces += [(a0, b0, b1), (a0, b1, a1)]        # side, normals outward
    faces += [(c0, a0, a1), (c1, b1, b0)]        # caps at y = -L (normal -y) and y = +L (+y)
out = pathlib.Path(__file__).resolve().parent.parent / "scenes" / "assets" / "bolster.obj"
with out.open("w") as f:
    f.write("# bolster: closed cylinder r = 0.06 m, axis y in [-0.4, 0.4] m (scripts/make_bolster.py)\n")
    for v in verts:
        f.write("v %.6f %.6f %.6f\n" % v)
    for t in faces:
        f.write("f %d %d %d\n" % t)
print(out)
