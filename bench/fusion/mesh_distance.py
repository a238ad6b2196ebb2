"""Distances between two meshes for the decimation benchmarks (Open3D ray casting)."""
import numpy as np
import open3d as o3d


def distances(a, b, n=300000):
    """Uniform samples on mesh a, unsigned distance to mesh b's surface (mm)."""
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(b))
    pts = np.asarray(a.sample_points_uniformly(n).points, np.float32)
    return scene.compute_distance(o3d.core.Tensor(pts)).numpy()


def quality(m, orig):
    """Mean and max distance of decimated mesh m to the original and back (mm)."""
    d1 = distances(m, orig)
    d2 = distances(orig, m)
    return {"triangles": len(m.triangles), "to_original_mean_mm": float(d1.mean()),
            "to_original_max_mm": float(d1.max()), "from_original_mean_mm": float(d2.mean()),
            "from_original_max_mm": float(d2.max())}


def largest_part_to_original(m, orig, n=300000):
    """Mean and max distance (mm) of the largest connected part of m (by area) to orig."""
    ids, _, areas = m.cluster_connected_triangles()
    ids, areas = np.asarray(ids), np.asarray(areas)
    part = o3d.geometry.TriangleMesh(m)
    part.remove_triangles_by_mask(ids != int(np.argmax(areas)))
    part.remove_unreferenced_vertices()
    d = distances(part, orig, int(n * areas.max() / areas.sum()))
    return {"triangles": len(part.triangles), "to_original_mean_mm": float(d.mean()),
            "to_original_max_mm": float(d.max())}
