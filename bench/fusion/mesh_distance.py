"""Distances between two meshes for the decimation benchmarks (Open3D ray casting).

Dense and deterministic: every triangle of the measured mesh is sampled with a fixed
barycentric pattern, k subdivisions per edge (k from its longest edge and a spacing, at
least 1): the (k+1)(k+2)/2 grid points, vertices included, and the centroids of the k^2
sub-triangles. The mean is the area-weighted mean over the centroids (midpoint rule);
the max and the 99.9th percentile (area-weighted) take all points. The same mesh pair
gives the same figures in every run.
"""
import numpy as np
import open3d as o3d


def _pattern(k):
    """Barycentric (u, v) of the grid points and of the sub-triangle centroids."""
    grid = [(i / k, j / k) for i in range(k + 1) for j in range(k + 1 - i)]
    cent = []
    for i in range(k):
        for j in range(k - i):
            cent.append(((3 * i + 1) / (3 * k), (3 * j + 1) / (3 * k)))  # upright
            if i + j < k - 1:
                cent.append(((3 * i + 2) / (3 * k), (3 * j + 2) / (3 * k)))  # inverted
    return np.array(grid, np.float64), np.array(cent, np.float64)


def surface_points(m, spacing):
    """(grid points, centroid points, centroid weights in mm^2) over every triangle of m."""
    v = np.asarray(m.vertices, np.float64)
    t = np.asarray(m.triangles, np.int64)
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    longest = np.max([np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1),
                      np.linalg.norm(a - c, axis=1)], axis=0)
    k_all = np.clip(np.ceil(longest / spacing), 1, 64).astype(np.int64)
    grids, cents, weights = [], [], []
    for k in np.unique(k_all):
        sel = k_all == k
        g, ce = _pattern(int(k))
        e1, e2, o = (b - a)[sel], (c - a)[sel], a[sel]
        for uv, out in ((g, grids), (ce, cents)):
            out.append((o[:, None, :] + uv[None, :, 0:1] * e1[:, None, :] +
                        uv[None, :, 1:2] * e2[:, None, :]).reshape(-1, 3))
        weights.append(np.repeat(area[sel] / (k * k), len(ce)))
    return np.concatenate(grids), np.concatenate(cents), np.concatenate(weights)


def median_edge(m):
    v = np.asarray(m.vertices, np.float64)
    t = np.asarray(m.triangles, np.int64)
    return float(np.median(np.linalg.norm(v[t[:, 1]] - v[t[:, 0]], axis=1)))


def distances(a, b, spacing):
    """Unsigned distances (mm) from a's surface to b's: grid points, centroids, weights."""
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(b))
    grid, cent, w = surface_points(a, spacing)

    def dist(p):
        out = []
        for s in range(0, len(p), 2_000_000):
            q = o3d.core.Tensor(p[s:s + 2_000_000].astype(np.float32))
            out.append(scene.compute_distance(q).numpy().astype(np.float64))
        return np.concatenate(out)

    return grid, dist(grid), dist(cent), w


def summary(a, b, spacing):
    """Mean, 99.9th percentile and max distance (mm) of a's surface to b's, and where the
    max is (a point on a)."""
    grid, dg, dc, w = distances(a, b, spacing)
    order = np.argsort(dc)
    cum = np.cumsum(w[order])
    p999 = float(dc[order][np.searchsorted(cum, 0.999 * cum[-1])])
    i = int(np.argmax(dg))
    worst = max(float(dg[i]), float(dc.max()))
    return {"mean_mm": float(np.sum(w * dc) / np.sum(w)), "p99_9_mm": p999, "max_mm": worst,
            "max_at": [round(float(x), 2) for x in grid[i]] if dg[i] >= dc.max() else None,
            "points": int(len(dg) + len(dc))}


def quality(m, orig, spacing=None):
    """Distances of decimated mesh m to the original and back (mm); spacing defaults to
    half the original's median edge."""
    spacing = spacing or 0.5 * median_edge(orig)
    to = summary(m, orig, spacing)
    back = summary(orig, m, spacing)
    out = {"triangles": len(m.triangles)}
    for name, s in (("to_original", to), ("from_original", back)):
        for key, val in s.items():
            out[f"{name}_{key}"] = val
    return out


def largest_part(m):
    """The largest connected part of m (by area)."""
    ids, _, areas = m.cluster_connected_triangles()
    ids, areas = np.asarray(ids), np.asarray(areas)
    part = o3d.geometry.TriangleMesh(m)
    part.remove_triangles_by_mask(ids != int(np.argmax(areas)))
    part.remove_unreferenced_vertices()
    return part


def largest_part_to_original(m, orig, spacing=None):
    """Distances (mm) of the largest connected part of m (by area) to orig."""
    spacing = spacing or 0.5 * median_edge(orig)
    part = largest_part(m)
    s = summary(part, orig, spacing)
    return {"triangles": len(part.triangles), **{f"to_original_{k}": v for k, v in s.items()}}
