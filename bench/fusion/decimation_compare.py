#!/usr/bin/env python3
"""Decimation quality, dome vs Open3D, on one mesh in one run.

  /usr/bin/python3 bench/fusion/decimation_compare.py DOME MESH.ply OUT_DIR [--ratio 0.1]
  /usr/bin/python3 bench/fusion/decimation_compare.py --ours DECIMATED.ply MESH.ply OUT_DIR

Decimates MESH.ply with `DOME mesh decimate --ratio R` (or takes dome's result as
given, e.g. fusion_bench's mesh_decimated.ply) and with Open3D's
simplify_quadric_decimation to the same triangle count, then measures both against the
original: mean, 99.9th percentile and max unsigned distance (mm) of the decimated surface
to the original surface, and of the original to the decimated one, each measured densely
and deterministically over every triangle (mesh_distance.py: a barycentric pattern at
half the original's median edge, so the max is reproducible, with the point where it
lies); also the decimated surface's largest connected part alone against the original
(the main surface, without floaters). Times: dome's decimation wall and CPU seconds (PLY
read and write apart, as `dome mesh decimate` prints them) and Open3D's, in the same run.
Prints JSON.
"""
import json, os, subprocess, sys, time

import open3d as o3d

from mesh_distance import largest_part_to_original, quality

args = sys.argv[1:]
ratio = "0.1"
if "--ratio" in args:
    i = args.index("--ratio")
    ratio = args[i + 1]
    del args[i:i + 2]
ours_path = None
if "--ours" in args:
    i = args.index("--ours")
    ours_path = args[i + 1]
    del args[i:i + 2]
    mesh_path, out = args[:2]
    dome_info = {}
else:
    dome, mesh_path, out = args[:3]
os.makedirs(out, exist_ok=True)
if ours_path is None:
    ours_path = os.path.join(out, "dome_decimated.ply")
    res = subprocess.run([dome, "mesh", "decimate", mesh_path, ours_path, "--ratio", ratio],
                         check=True, capture_output=True, text=True)
    dome_info = json.loads(res.stdout.strip().splitlines()[-1])
orig = o3d.io.read_triangle_mesh(mesh_path)
ours = o3d.io.read_triangle_mesh(ours_path)
t0, c0 = time.perf_counter(), time.process_time()
theirs = orig.simplify_quadric_decimation(target_number_of_triangles=len(ours.triangles))
t_o3d, c_o3d = time.perf_counter() - t0, time.process_time() - c0
o3d.io.write_triangle_mesh(os.path.join(out, "open3d_decimated.ply"), theirs)
print(json.dumps({"mesh": mesh_path, "original_triangles": len(orig.triangles),
                  "dome": quality(ours, orig), "dome_largest_part": largest_part_to_original(ours, orig),
                  "dome_run": dome_info,
                  "open3d": quality(theirs, orig),
                  "open3d_largest_part": largest_part_to_original(theirs, orig),
                  "open3d_seconds": t_o3d, "open3d_cpu_seconds": c_o3d}, indent=1))
