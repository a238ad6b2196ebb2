#!/usr/bin/python3
"""Flicker of a reconstructed sequence over the scene's still parts, and accuracy on
its moving parts, against a synthetic take's truth (dome synth).

Usage: flicker.py TAKE OUT [OUT2 ...]   (one JSON line per OUT)

Still and moving parts come from the truth alone: a vertex of the truth mesh at
instant t is still when the truth mesh at t+1 has a vertex within 0.01 mm of it (the
floor, the walls, what stands there), moving otherwise (the batter and the bat).
For each pair of consecutive instants (t, t+1), the reconstructed surface's vertices
at t (OUT/<t>/mesh.ply, mm) that lie within 20 mm of a still truth vertex and farther
than 300 mm from every moving truth vertex of t and t+1 are measured against the
reconstructed surface at t+1: flicker is the RMS of those distances (mm), the surface's
frame-to-frame displacement where nothing moved. Moving accuracy: the median distance
from the reconstructed vertices at t within 50 mm of a moving truth vertex of t to
the truth mesh at t (mm), median over the instants. Printed: medians over the pairs.
"""
import json
import os
import sys

import numpy as np
import open3d as o3d
from scipy.spatial import cKDTree


def load(path):
    m = o3d.io.read_triangle_mesh(path)
    return m, np.asarray(m.vertices, np.float64)


def distance_to(mesh, points):
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(mesh))
    return scene.compute_distance(o3d.core.Tensor(points.astype(np.float32))).numpy()


def main():
    take, outs = sys.argv[1], sys.argv[2:]
    instants = sorted(os.listdir(os.path.join(take, "truth")))
    truth = [load(os.path.join(take, "truth", t, "mesh.ply")) for t in instants]
    still, moving = [], []
    for k in range(len(instants) - 1):
        a, b = truth[k][1], truth[k + 1][1]
        d, _ = cKDTree(b).query(a)
        still.append(a[d < 0.01])
        moving.append(a[d >= 0.01])
    last_d, _ = cKDTree(truth[-2][1]).query(truth[-1][1])
    moving.append(truth[-1][1][last_d >= 0.01])
    for out in outs:
        flicker, kept, moving_acc = [], [], []
        for k in range(len(instants) - 1):
            m0, v0 = load(os.path.join(out, instants[k], "mesh.ply"))
            m1, _ = load(os.path.join(out, instants[k + 1], "mesh.ply"))
            near_still, _ = cKDTree(still[k]).query(v0)
            far_moving, _ = cKDTree(np.vstack([moving[k], moving[k + 1]])).query(v0)
            sel = v0[(near_still < 20) & (far_moving > 300)]
            d = distance_to(m1, sel)
            flicker.append(float(np.sqrt(np.mean(d * d))))
            kept.append(len(sel))
        for k in range(len(instants)):
            _, v = load(os.path.join(out, instants[k], "mesh.ply"))
            near_moving, _ = cKDTree(moving[k]).query(v)
            on = v[near_moving < 50]
            if len(on):
                moving_acc.append(float(np.median(distance_to(truth[k][0], on))))
        print(json.dumps({
            "out": out,
            "flicker_rms_mm_median": round(float(np.median(flicker)), 3),
            "flicker_rms_mm": [round(f, 3) for f in flicker],
            "still_vertices_median": int(np.median(kept)),
            "moving_accuracy_mm_median": round(float(np.median(moving_acc)), 3),
        }))


if __name__ == "__main__":
    main()
