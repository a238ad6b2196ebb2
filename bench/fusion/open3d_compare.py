#!/usr/bin/env python3
"""Fusion speed and decimation quality, dome vs Open3D, in one run on the same data.

  /usr/bin/python3 bench/fusion/open3d_compare.py FUSION_BENCH TAKE INSTANT OUT [--threads 2]
      [--pairs 3]

1. Runs dome's fusion_bench (fusion of the instant's truth depth maps with noise into
   the seed's 300^3 volume of 20 mm, marching cubes, decimation to 10 %, texture) and
   keeps its JSON (per-stage seconds); it also writes the exact depth maps it fused.
2. Fusion speed in --pairs back-to-back pairs, alternating which goes first: dome's
   fusion alone (fusion_bench --fusion-only 1 --repeat 2: the better of two instants
   fused in one process, tables built each time, the second in the first one's table
   memory as in a worker) and Open3D's legacy UniformTSDFVolume
   (6 m cube, 300^3, sdf_trunc = 3 voxels, OMP_NUM_THREADS = threads; the better of two
   fresh volumes, allocation not timed) on the same depth maps, with the undistorted
   pinhole K of each camera (Open3D has no Tsai distortion: the timing is what is
   compared). Each pair gives a ratio of wall times and one of process CPU times (all
   threads); on a machine shared with other work the load changes within a run, and a
   pair's two halves see nearly the same load. The median ratio, with the least and
   largest, is reported.
3. Decimation quality at 10 % of the triangles of dome's marching-cubes mesh: dome's
   (quadric edge collapse, common/mesh/decimate.h) vs Open3D's simplify_quadric_decimation -- mean and max distance of
   dense samples of the decimated surface to the original mesh, and back.
Prints one JSON object.
"""
import json, os, subprocess, sys, time

threads = "2"
pairs = 3
args = [a for a in sys.argv[1:]]
if "--threads" in args:
    i = args.index("--threads")
    threads = args[i + 1]
    del args[i:i + 2]
if "--pairs" in args:
    i = args.index("--pairs")
    pairs = int(args[i + 1])
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



def dome_fusion():
    r = subprocess.run([bench, take, instant, out, "--threads", threads, "--slab-planes", "32",
                        "--repeat", "2", "--fusion-only", "1"],
                       check=True, capture_output=True, text=True)
    d = json.loads(r.stdout.strip().splitlines()[-1])
    return d["fusion_s"], d["fusion_cpu_s"]


def open3d_fusion():
    best = None
    for rep in range(2):
        vol = o3d.pipelines.integration.UniformTSDFVolume(
            length=6.0, resolution=300, sdf_trunc=0.06,
            color_type=o3d.pipelines.integration.TSDFVolumeColorType.NoColor,
            origin=np.array([-3.0, -3.0, -2.75]).reshape(3, 1))
        t0, c0 = time.perf_counter(), time.process_time()
        for rgbd, K, E in frames:
            vol.integrate(rgbd, K, E)
        run = (time.perf_counter() - t0, time.process_time() - c0, vol)
        if best is None or run[0] < best[0]:
            best = run
    return best


runs = []
for p in range(pairs):
    if p % 2 == 0:
        dw, dc = dome_fusion()
        ow, oc, vol = open3d_fusion()
    else:
        ow, oc, vol = open3d_fusion()
        dw, dc = dome_fusion()
    runs.append({"dome_s": dw, "dome_cpu_s": dc, "open3d_s": ow, "open3d_cpu_s": oc,
                 "ratio": ow / dw, "cpu_ratio": oc / dc})


def spread(key):
    v = sorted(r[key] for r in runs)
    return {"median": float(np.median(v)), "min": v[0], "max": v[-1]}


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
    "fusion_pairs": runs,
    "fusion_speedup_vs_open3d": spread("ratio"),
    "fusion_cpu_speedup_vs_open3d": spread("cpu_ratio"),
    "dome_fusion_s": spread("dome_s"),
    "open3d_uniform_tsdf_s": spread("open3d_s"),
    "open3d_extract_mesh_s": t_o3d_mc,
    "open3d_triangles": len(o3d_mesh.triangles),
    "decimation_10pct": {"dome": quality(ours, orig), "open3d": quality(theirs, orig),
                         "open3d_seconds": t_o3d_dec, "dome_seconds": dome["decimation_s"]},
}
print(json.dumps(report, indent=1))
