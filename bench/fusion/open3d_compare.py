#!/usr/bin/env python3
"""Fusion speed and decimation quality, dome vs Open3D, in one run on the same data.

  /usr/bin/python3 bench/fusion/open3d_compare.py FUSION_BENCH TAKE INSTANT OUT [--threads 2]

1. Runs dome's fusion_bench (fusion of the instant's truth depth maps with noise into
   the seed's 300^3 volume of 20 mm, marching cubes, decimation to 10 %, texture) and
   keeps its JSON; it also writes the exact depth maps it fused.
2. Fuses the same depth maps with Open3D's legacy UniformTSDFVolume (6 m cube, 300^3,
   sdf_trunc = 3 voxels) with OMP_NUM_THREADS = threads; the undistorted pinhole K of
   each camera (Open3D has no Tsai distortion: the timing is what is compared).
3. Decimation quality at 10 % of the triangles of dome's marching-cubes mesh: dome's
   (meshoptimizer) vs Open3D's simplify_quadric_decimation -- mean and max distance of
   dense samples of the decimated surface to the original mesh, and back.
Prints one JSON object.
"""
import json, os, subprocess, sys, time

threads = "2"
args = [a for a in sys.argv[1:]]
if "--threads" in args:
    i = args.index("--threads")
    threads = args[i + 1]
    del args[i:i + 2]
os.environ["OMP_NUM_THREADS"] = threads
import numpy as np
import open3d as o3d

from mesh_distance import quality

bench, take, instant, out = args[:4]
res = subprocess.run([bench, take, instant, out, "--threads", threads, "--slab-planes", "32"],
                     check=True, capture_output=True, text=True)
dome = json.loads(res.stdout.strip().splitlines()[-1])

cams = json.load(open(os.path.join(out, "cameras.json")))
frames = []
for c in cams:
    d = np.fromfile(os.path.join(out, "depth", c["id"] + ".f32"), dtype="<f4").reshape(c["height"], c["width"])
    depth = o3d.geometry.Image(np.ascontiguousarray(d))
    colour = o3d.geometry.Image(np.zeros((c["height"], c["width"], 3), np.uint8))
    rgbd = o3d.geometry.RGBDImage.create_from_color_and_depth(
        colour, depth, depth_scale=1000.0, depth_trunc=10.0, convert_rgb_to_intensity=False)
    K = o3d.camera.PinholeCameraIntrinsic(c["width"], c["height"], c["fx"], c["fy"], c["cx"], c["cy"])
    E = np.eye(4)
    E[:3, :3] = np.array(c["R"]).reshape(3, 3)
    E[:3, 3] = np.array(c["t"]) / 1000.0
    frames.append((rgbd, K, E))

best = 1e30
for rep in range(2):
    vol = o3d.pipelines.integration.UniformTSDFVolume(
        length=6.0, resolution=300, sdf_trunc=0.06,
        color_type=o3d.pipelines.integration.TSDFVolumeColorType.NoColor,
        origin=np.array([-3.0, -3.0, -2.75]).reshape(3, 1))
    t0 = time.perf_counter()
    for rgbd, K, E in frames:
        vol.integrate(rgbd, K, E)
    best = min(best, time.perf_counter() - t0)
t0 = time.perf_counter()
o3d_mesh = vol.extract_triangle_mesh()
t_o3d_mc = time.perf_counter() - t0

# Decimation quality on dome's marching-cubes mesh.
orig = o3d.io.read_triangle_mesh(os.path.join(out, "mesh.ply"))
ours = o3d.io.read_triangle_mesh(os.path.join(out, "mesh_decimated.ply"))
target = len(ours.triangles)
t0 = time.perf_counter()
theirs = orig.simplify_quadric_decimation(target_number_of_triangles=target)
t_o3d_dec = time.perf_counter() - t0



o3d.utility.random.seed(1)
report = {
    "dome": dome,
    "open3d_uniform_tsdf_s": best,
    "open3d_extract_mesh_s": t_o3d_mc,
    "open3d_triangles": len(o3d_mesh.triangles),
    "fusion_speedup_vs_open3d": best / dome["fusion_s"],
    "decimation_10pct": {"dome": quality(ours, orig), "open3d": quality(theirs, orig),
                         "open3d_seconds": t_o3d_dec, "dome_seconds": dome["decimation_s"]},
}
print(json.dumps(report, indent=1))
