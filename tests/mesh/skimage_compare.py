#!/usr/bin/env python3
"""dome's marching cubes against scikit-image's measure.marching_cubes on the same
volumes (written by mc_dump): surface area within 0.5 %, symmetric Hausdorff distance
between the vertex sets under 0.01 voxel.  Usage: skimage_compare.py MC_DUMP OUT_DIR.
Exit 0 = pass; 77 = skipped (scikit-image missing)."""
import json, os, struct, subprocess, sys

import numpy as np
try:
    from skimage import measure
    from scipy.spatial import cKDTree
except ImportError as e:  # pragma: no cover
    print("SKIP:", e)
    sys.exit(77)


def read_ply(path):
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    nv = nf = 0
    props = []
    for line in header:
        t = line.split()
        if t[:2] == ["element", "vertex"]:
            nv = int(t[2])
        elif t[:2] == ["element", "face"]:
            nf = int(t[2])
        elif t[0] == "property" and nf == 0 and t[1] != "list":
            props.append(t[1])
    assert all(p == "float" for p in props), props
    stride = 4 * len(props)
    v = np.frombuffer(data, dtype="<f4", count=nv * len(props), offset=end).reshape(nv, len(props))[:, :3]
    off = end + nv * stride
    f = np.frombuffer(data, dtype=np.dtype([("n", "u1"), ("i", "<i4", 3)]), count=nf, offset=off)
    assert (f["n"] == 3).all()
    return v.astype(np.float64), f["i"].astype(np.int64)


def area(v, f):
    return 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum()


def main():
    tool, out = sys.argv[1], sys.argv[2]
    subprocess.run([tool, out], check=True)
    ok = True
    for name in ("sphere", "torus", "blobs"):
        meta = json.load(open(os.path.join(out, name + ".json")))
        vol = np.fromfile(os.path.join(out, name + ".raw"), dtype="<f4").reshape(meta["nz"], meta["ny"], meta["nx"])
        s = meta["voxel_size_mm"]
        o = np.array(meta["origin_mm"])
        vs, fs, _, _ = measure.marching_cubes(vol, level=0.0)
        vs = o + (vs[:, ::-1] + 0.5) * s  # (k, j, i) index -> world x y z
        vd, fd = read_ply(os.path.join(out, name + ".ply"))
        a_s, a_d = area(vs, fs), area(vd, fd)
        d1, _ = cKDTree(vs).query(vd)
        d2, _ = cKDTree(vd).query(vs)
        hausdorff_vox = max(d1.max(), d2.max()) / s
        rel = abs(a_d - a_s) / a_s
        good = rel < 0.005 and hausdorff_vox < 0.01
        ok &= good
        print(f"{name}: area dome {a_d:.2f} mm^2, skimage {a_s:.2f} mm^2 (diff {100 * rel:.4f} %), "
              f"Hausdorff {hausdorff_vox:.2e} voxel, vertices {len(vd)} / {len(vs)}, "
              f"triangles {len(fd)} / {len(fs)}: {'ok' if good else 'FAIL'}")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
