#!/usr/bin/env python3
"""Decimation speed, two dome binaries side by side on one mesh (before / after).

  /usr/bin/python3 bench/fusion/decimation_ab.py BEFORE_DOME AFTER_DOME MESH.ply [--pairs N]
      [--after "OPTIONS"] [--quality] [-- DECIMATE_OPTIONS...]

Runs `DOME mesh decimate MESH OUT DECIMATE_OPTIONS` N times (default 7) per binary,
alternating before / after, and prints JSON: per binary the decimation's CPU seconds and
wall seconds (as `dome mesh decimate` prints them, PLY read and write apart; the CPU
seconds are the process's, all threads), their medians, and the median over the pairs of
after / before (CPU and wall). The outputs of the last pair are compared byte for byte
("same_output"). On a machine shared with other work the CPU seconds are the steadier
figure of one thread; medians over many pairs even out the rest.

--after "OPTIONS": options for the after binary only (e.g. "--threads 2", which the
before binary may not know), after DECIMATE_OPTIONS. --quality: each output's distances
to MESH and back (mesh_distance.quality: mean, 99.9th percentile, max, mm).
"""
import json, os, statistics, subprocess, sys, tempfile

args = sys.argv[1:]
extra = []
if "--" in args:
    i = args.index("--")
    args, extra = args[:i], args[i + 1:]
pairs = 7
if "--pairs" in args:
    i = args.index("--pairs")
    pairs = int(args[i + 1])
    del args[i:i + 2]
after_extra = []
if "--after" in args:
    i = args.index("--after")
    after_extra = args[i + 1].split()
    del args[i:i + 2]
with_quality = "--quality" in args
if with_quality:
    args.remove("--quality")
if len(args) != 3 or pairs < 1:
    sys.exit("usage: decimation_ab.py BEFORE_DOME AFTER_DOME MESH.ply [--pairs N] "
             "[--after \"OPTIONS\"] [--quality] [-- OPTIONS]")
before, after, mesh = args
out_dir = tempfile.mkdtemp(prefix="decimation_ab_")


def run(dome, out, own):
    res = subprocess.run([dome, "mesh", "decimate", mesh, out] + extra + own, check=True,
                         capture_output=True, text=True)
    line = json.loads(res.stdout.strip().splitlines()[-1])
    return line["cpu_seconds"], line["seconds"], line["triangles_out"]


runs = {"before": [], "after": []}
for p in range(pairs):
    for name, dome in (("before", before), ("after", after)):
        runs[name].append(run(dome, os.path.join(out_dir, name + ".ply"),
                              after_extra if name == "after" else []))
with open(os.path.join(out_dir, "before.ply"), "rb") as a, \
        open(os.path.join(out_dir, "after.ply"), "rb") as b:
    same = a.read() == b.read()
report = {"mesh": mesh, "options": extra, "after_options": after_extra, "pairs": pairs,
          "same_output": same}
for name in runs:
    cpu = [r[0] for r in runs[name]]
    wall = [r[1] for r in runs[name]]
    report[name] = {"binary": before if name == "before" else after,
                    "triangles_out": runs[name][-1][2], "cpu_s": cpu, "wall_s": wall,
                    "cpu_median_s": statistics.median(cpu),
                    "wall_median_s": statistics.median(wall)}
report["after_over_before_cpu"] = statistics.median(
    a[0] / b[0] for a, b in zip(runs["after"], runs["before"]))
report["after_over_before_wall"] = statistics.median(
    a[1] / b[1] for a, b in zip(runs["after"], runs["before"]))
if with_quality:
    import open3d as o3d
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from mesh_distance import quality
    orig = o3d.io.read_triangle_mesh(mesh)
    for name in runs:
        q = quality(o3d.io.read_triangle_mesh(os.path.join(out_dir, name + ".ply")), orig)
        report[name]["quality"] = {k: v for k, v in q.items() if not k.endswith("_at")}
print(json.dumps(report, indent=1))
