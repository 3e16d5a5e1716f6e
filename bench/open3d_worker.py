"""Open3D peer of the benchmark: one cloud, Open3D ``PointCloud.estimate_normals`` (PCA over the
K nearest neighbours, ``KDTreeSearchParamKNN``), run in its own process by nhnet_bench.py.

    python open3d_worker.py GT_XYZN K OUT_XYZN

Reads the noisy points (first 3 columns of GT_XYZN), times only ``estimate_normals`` (wall
seconds; Open3D's OpenMP threads follow OMP_NUM_THREADS), writes ``x y z nx ny nz`` to OUT_XYZN
(scored afterwards by ``nhnet-cli eval``, i.e. nhnet's metrics) and prints one JSON line.
"""
import json
import sys
import time


def rss_mb() -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return 0.0


def main() -> int:
    gt, k, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    import numpy as np
    import open3d as o3d

    pts = np.loadtxt(gt, usecols=(0, 1, 2), dtype=np.float64)
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(pts))
    before = rss_mb()
    t0 = time.perf_counter()
    cloud.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=k))
    secs = time.perf_counter() - t0
    normals = np.asarray(cloud.normals)
    np.savetxt(out, np.hstack([pts, normals]), fmt="%.9g")
    print(json.dumps({"method": "open3d", "k": k, "points": int(pts.shape[0]), "time_s": secs,
                      "rss_before_mb": before, "version": o3d.__version__}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
