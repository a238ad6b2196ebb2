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
