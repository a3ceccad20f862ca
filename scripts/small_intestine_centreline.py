#!/usr/bin/env python3
"""Writes scenes/assets/small-intestine-centreline.json: a procedural small intestine for a
12.5 mm tube, folded in two layers in a 0.30 x 0.24 m abdominal box: six rows along x on the floor
joined by U-turns, a rise, and six rows along y lying across them. A polyline through corner
waypoints with every corner rounded by an arc; points about every 5 mm.
Run from the repository root: python3 scripts/small_intestine_centreline.py"""
import json
import math

R = 0.0125                 # tube radius, m
STEP = 0.005               # point spacing, m
Z1 = R + 0.001             # first layer: just above the floor
Z2 = Z1 + 2 * R + 0.004    # second layer: across the first, 4 mm above it


def sub(a, b): return [a[i] - b[i] for i in range(3)]
def add(a, b): return [a[i] + b[i] for i in range(3)]
def mul(a, s): return [x * s for x in a]
def dot(a, b): return sum(a[i] * b[i] for i in range(3))
def norm(a): return math.sqrt(dot(a, a))
def unit(a): return mul(a, 1.0 / norm(a))


def waypoints():
    w = []
    x0, x1, dy = 0.03, 0.27, 0.035
    for j in range(6):                      # layer 1: rows along x
        y = 0.03 + dy * j
        ends = (x0, x1) if j % 2 == 0 else (x1, x0)
        w += [[ends[0], y, Z1], [ends[1], y, Z1]]
    w += [[0.03, 0.225, Z1 + 0.004]]         # turn towards the back wall and rise
    x, dx = 0.045, 0.04
    for j in range(6):                      # layer 2: rows along y, across layer 1
        ends = (0.225, 0.035) if j % 2 == 0 else (0.035, 0.225)
        w += [[x + dx * j, ends[0], Z2], [x + dx * j, ends[1], Z2]]
    # the first waypoint after the rise repeats the rise's corner height change smoothly
    return w


def rounded(w, radius):
    """Polyline through w with each interior corner replaced by an arc of up to `radius`."""
    out = [w[0]]
    for i in range(1, len(w) - 1):
        p = w[i]
        a = unit(sub(p, w[i - 1]))
        b = unit(sub(w[i + 1], p))
        theta = math.acos(max(-1.0, min(1.0, dot(a, b))))
        if theta < 1e-9:
            continue
        # the arc may use at most half of each neighbouring run
        rho = min(radius, 0.5 * min(norm(sub(p, w[i - 1])), norm(sub(w[i + 1], p))) / math.tan(theta / 2))
        d = rho * math.tan(theta / 2)
        start = sub(p, mul(a, d))
        out += straight(out[-1], start)
        n = unit(sub(b, mul(a, dot(a, b))))
        centre = add(start, mul(n, rho))
        steps = max(2, round(theta * rho / STEP))
        for k in range(1, steps + 1):
            phi = theta * k / steps
            out.append(add(centre, add(mul(n, -rho * math.cos(phi)), mul(a, rho * math.sin(phi)))))
    out += straight(out[-1], w[-1])
    return out


def straight(a, b):
    n = round(norm(sub(b, a)) / STEP)
    return [add(a, mul(sub(b, a), k / n)) for k in range(1, n + 1)] if n > 0 else []


def write_centreline(points, path, layout, script):
    """The centreline as the scene format's JSON polyline (metres), with its length and source."""
    length = sum(norm(sub(points[i + 1], points[i])) for i in range(len(points) - 1))
    doc = {
        "units": "m",
        "source": "procedural small intestine, %s (%s); %.3f m, %d points" % (layout, script, length, len(points)),
        "points": [[round(c, 6) for c in p] for p in points],
    }
    with open(path, "w") as f:
        json.dump(doc, f, indent=None, separators=(",", ":"))
        f.write("\n")
    print("wrote %s: %.3f m, %d points" % (path, length, len(points)))


def main():
    write_centreline(rounded(waypoints(), 0.0175), "scenes/assets/small-intestine-centreline.json",
                     "two layers in a 0.30 x 0.24 m box", "scripts/small_intestine_centreline.py")


if __name__ == "__main__":
    main()
