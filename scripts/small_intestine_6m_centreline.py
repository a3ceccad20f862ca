#!/usr/bin/env python3
"""Writes scenes/assets/small-intestine-6m-centreline.json: a whole small intestine (about 6 m) for
a 12.5 mm tube, folded in four layers in a 0.30 x 0.24 m abdominal box (issue 29's scene): rows along
x, then rows along y across them, twice, each layer rising over the last. A polyline through corner
waypoints with every corner rounded by an arc (as scripts/small_intestine_centreline.py); points
about every 5 mm. Run from the repository root: python3 scripts/small_intestine_6m_centreline.py"""
from small_intestine_centreline import rounded, write_centreline

R = 0.0125                 # tube radius, m
GAP = 0.004                # between layers
X0, X1 = 0.03, 0.28        # rows along x span this
Y0, Y1 = 0.03, 0.195       # rows along y span this
PITCH = 0.034              # between neighbouring rows of one layer (2R + 9 mm)


def layer_z(k):
    return R + 0.001 + k * (2 * R + GAP)


def waypoints():
    w = []
    for k in range(4):
        z = layer_z(k)
        along_x = k % 2 == 0
        lo, hi = (Y0, Y1) if along_x else (X0, X1)
        a, b = (X0, X1) if along_x else (Y0, Y1)
        rows = int((hi - lo) / PITCH) + 1
        flip = (k // 2) % 2 == 1   # the second pair of layers runs back over the first
        for j in range(rows):
            c = hi - PITCH * j if flip else lo + PITCH * j
            ends = (a, b) if j % 2 == 0 else (b, a)
            for e in ends:
                w.append([e, c, z] if along_x else [c, e, z])
    return w


def main():
    write_centreline(rounded(waypoints(), 0.0165), "scenes/assets/small-intestine-6m-centreline.json",
                     "four layers in a 0.30 x 0.24 m box", "scripts/small_intestine_6m_centreline.py")


if __name__ == "__main__":
    main()
