#!/usr/bin/env python3
"""Generates the demo's hand-made target models as triangle meshes (ASCII PLY, metres).

Conventions of every projtour model: origin at the centroid (here: of the surface area, close
enough to the vertex centroid for alignment), z up, the front faces +x.

  sign.ply   a poster board on a post and a square foot: a 0.60 x 0.45 m board with a raised
             frame at its sides and a ledge along its bottom. The board alone would be a plane
             (ICP slides in it); from a camera above the board's middle the ledge's top face pins
             the height and the frame's inner faces pin the sideways position.
  pillar.ply a round pillar wrap (r = 0.20 m) on a tall square plinth. A bare cylinder is free
             to turn about its axis and slide along it; the plinth's front and top faces, in view
             of a camera at head height, break both.

Run: python3 make_models.py   (writes both files beside this script)
"""
import math
import os


def box(cx, cy, cz, sx, sy, sz):
    """Axis-aligned box as 12 outward-facing triangles."""
    hx, hy, hz = sx / 2, sy / 2, sz / 2
    v = [(cx + dx * hx, cy + dy * hy, cz + dz * hz)
         for dx in (-1, 1) for dy in (-1, 1) for dz in (-1, 1)]
    # vertex index = (dx>0)*4 + (dy>0)*2 + (dz>0)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return v, quads_to_tris(quads)


def quads_to_tris(quads):
    tris = []
    for a, b, c, d in quads:
        tris += [(a, b, c), (a, c, d)]
    return tris


def subdivided_box(cx, cy, cz, sx, sy, sz, step):
    """Box whose faces are gridded at about `step`, so surface sampling and rendering see an
    even triangle size."""
    verts, tris = [], []
    h = (sx / 2, sy / 2, sz / 2)
    c = (cx, cy, cz)
    for axis in range(3):
        u_axis, v_axis = [a for a in range(3) if a != axis]
        nu = max(1, round(2 * h[u_axis] / step))
        nv = max(1, round(2 * h[v_axis] / step))
        for sign in (-1, 1):
            base = len(verts)
            for i in range(nu + 1):
                for j in range(nv + 1):
                    p = [0.0, 0.0, 0.0]
                    p[axis] = c[axis] + sign * h[axis]
                    p[u_axis] = c[u_axis] - h[u_axis] + 2 * h[u_axis] * i / nu
                    p[v_axis] = c[v_axis] - h[v_axis] + 2 * h[v_axis] * j / nv
                    verts.append(tuple(p))
            for i in range(nu):
                for j in range(nv):
                    a = base + i * (nv + 1) + j
                    b, d = a + (nv + 1), a + 1
                    e = b + 1
                    # Orientation so normals point out: depends on axis order and sign.
                    if (sign > 0) == ((u_axis, v_axis) in ((1, 2), (2, 0), (0, 1))):
                        tris += [(a, b, e), (a, e, d)]
                    else:
                        tris += [(a, e, b), (a, d, e)]
    return verts, tris


def cylinder(cx, cy, z0, z1, r, segments, rings):
    verts, tris = [], []
    for k in range(rings + 1):
        z = z0 + (z1 - z0) * k / rings
        for s in range(segments):
            a = 2 * math.pi * s / segments
            verts.append((cx + r * math.cos(a), cy + r * math.sin(a), z))
    for k in range(rings):
        for s in range(segments):
            a = k * segments + s
            b = k * segments + (s + 1) % segments
            tris += [(a, b, b + segments), (a, b + segments, a + segments)]
    return verts, tris


def merge(parts):
    verts, tris = [], []
    for v, t in parts:
        base = len(verts)
        verts += v
        tris += [(a + base, b + base, c + base) for a, b, c in t]
    return verts, tris


def area_centroid(verts, tris):
    total, acc = 0.0, [0.0, 0.0, 0.0]
    for a, b, c in tris:
        pa, pb, pc = verts[a], verts[b], verts[c]
        u = [pb[i] - pa[i] for i in range(3)]
        w = [pc[i] - pa[i] for i in range(3)]
        n = (u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0])
        area = 0.5 * math.sqrt(sum(x * x for x in n))
        total += area
        for i in range(3):
            acc[i] += area * (pa[i] + pb[i] + pc[i]) / 3
    return [x / total for x in acc]


def write_ply(path, comment, verts, tris):
    c = area_centroid(verts, tris)
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\n")
        for line in comment:
            f.write(f"comment {line}\n")
        f.write(f"comment origin moved to the surface-area centroid (was {c[0]:.4f} {c[1]:.4f} {c[2]:.4f})\n")
        f.write(f"element vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\n")
        f.write(f"element face {len(tris)}\nproperty list uchar int vertex_indices\nend_header\n")
        for v in verts:
            f.write(f"{v[0] - c[0]:.6f} {v[1] - c[1]:.6f} {v[2] - c[2]:.6f}\n")
        for t in tris:
            f.write(f"3 {t[0]} {t[1]} {t[2]}\n")
    return c


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    step = 0.05
    # Sign: foot on the floor (z = 0), post, board 0.60 wide x 0.45 high x 0.04 deep, top at 1.2 m
    # (low enough that a Kinect at head height sees all of it from 1 m).
    sign = merge([
        subdivided_box(0.0, 0.0, 0.025, 0.40, 0.40, 0.05, step),     # foot
        subdivided_box(0.0, 0.0, 0.40, 0.06, 0.06, 0.70, step),      # post
        subdivided_box(0.05, 0.0, 0.975, 0.04, 0.60, 0.45, step),    # board, front face x = 0.07
        subdivided_box(0.09, -0.28, 0.995, 0.04, 0.04, 0.41, 0.02),  # frame, left
        subdivided_box(0.09, 0.28, 0.995, 0.04, 0.04, 0.41, 0.02),   # frame, right
        subdivided_box(0.12, 0.0, 0.77, 0.10, 0.60, 0.04, 0.02),     # ledge along the bottom
    ])
    c = write_ply(os.path.join(here, "sign.ply"),
                  ["projtour demo sign, generated by make_models.py (CC0)",
                   "metres, z up, front = +x; board front face at x = 0.07 before centring"],
                  *sign)
    print("sign centroid", c)
    # Pillar: square plinth 0.56 x 0.56 x 0.45, round shaft r = 0.20 up to 1.5 m, square cap.
    pillar = merge([
        subdivided_box(0.0, 0.0, 0.225, 0.56, 0.56, 0.45, step),
        cylinder(0.0, 0.0, 0.45, 1.50, 0.20, 72, 21),
        subdivided_box(0.0, 0.0, 1.55, 0.50, 0.50, 0.10, step),
    ])
    c = write_ply(os.path.join(here, "pillar.ply"),
                  ["projtour demo pillar wrap, generated by make_models.py (CC0)",
                   "metres, z up, front = +x"],
                  *pillar)
    print("pillar centroid", c)


if __name__ == "__main__":
    main()
