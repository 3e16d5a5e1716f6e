"""The gallery (docs/gallery/README.md): three virtual scans with their sensor in the file, their
normals before (`--orient mst`, the default before `auto`) and after (no flag), shaded.

    PYTHONPATH=training:tools /usr/bin/python3 docs/gallery/make_gallery.py [--cli build/cli/nhnet-cli] [--out docs/gallery]

Writes each scan as a user's scanner software would (an organized PCD with VIEWPOINT (tools/depth_scan.py), an E57 of
two stations with their poses via pye57, a LAS 1.4 survey via laspy), runs nhnet-cli twice on
it, and renders the normals: grey shading lit from each point's own sensor, red where a normal
faces away from the sensor that saw the point. Prints the share of valid normals facing the
sensor for both runs.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import depth_scan
import virtual_scan as vs

HERE = Path(__file__).resolve().parent


def run_cli(cli: str, src: Path, out: Path, flags: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """nhnet-cli estimate SRC OUT FLAGS; returns the output's points and normals."""
    subprocess.run([cli, "estimate", str(src), str(out), "--overwrite", *flags], check=True)
    import nhnet
    cloud = nhnet.read(str(out))
    return np.asarray(cloud.points), np.asarray(cloud.normals)


def facing(points: np.ndarray, normals: np.ndarray, towards: np.ndarray) -> np.ndarray:
    """Cosine between each normal and the direction to its sensor (`towards`: N x 3 positions,
    or a 3-vector direction when the sensor is at infinity, as for airborne lidar)."""
    d = towards - points if towards.ndim == 2 else np.broadcast_to(towards, points.shape)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    return np.einsum("ij,ij->i", d, normals)


def render(points, normals, cosines, eye, target, size=(320, 240)) -> np.ndarray:
    """RGB image of the points seen from `eye`, lit from the eye (|n . view|, so the shape shows
    whatever the sign): grey where the normal faces its sensor, red where it faces away."""
    w, h = size
    rot = vs.look_at(eye, target)
    cam = (points - eye) @ rot
    f = 0.9 * w
    ok = np.isfinite(cosines) & (cam[:, 2] > 0)
    u = np.floor(f * cam[ok, 0] / cam[ok, 2] + w / 2).astype(np.int64)
    v = np.floor(f * cam[ok, 1] / cam[ok, 2] + h / 2).astype(np.int64)
    inside = (u >= 0) & (u < w) & (v >= 0) & (v < h)
    pix, z = v[inside] * w + u[inside], cam[ok, 2][inside]
    view = eye - points[ok][inside]
    light = np.abs(np.einsum("ij,ij->i", normals[ok][inside], view)) / np.linalg.norm(view, axis=1)
    colour = np.where((cosines[ok][inside] >= 0)[:, None], [[1.0, 1.0, 1.0]], [[1.0, 0.2, 0.15]])
    colour *= (0.2 + 0.8 * light)[:, None]
    order = np.lexsort((z, pix))  # nearest point of each pixel first
    first = np.unique(pix[order], return_index=True)[1]
    img = np.ones((h * w, 3))
    img[pix[order][first]] = colour[order][first]
    return img.reshape(h, w, 3)


def panel(path: Path, images: list[np.ndarray], titles: list[str]) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(images), figsize=(4.8 * len(images), 3.9), dpi=100)
    for ax, img, title in zip(axes, images, titles):
        ax.imshow(img)
        ax.set_title(title, fontsize=10)
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def gallery_item(cli, work, out_dir, name, src, towards, view, flags):
    """Runs before/after on one scan, renders `name`.png, returns both facing shares."""
    shares, images = [], []
    for label, extra in (("before", ["--orient", "mst"]), ("after", [])):
        pts, nrm = run_cli(cli, src, work / f"{name}_{label}.ply", flags + extra)
        cos = facing(pts, nrm, towards)
        valid = np.isfinite(cos)
        shares.append(100.0 * float(np.mean(cos[valid] > 0)))
        images.append(render(pts, nrm, cos, *view))
    panel(out_dir / f"{name}.png", images,
          [f"before: --orient mst ({shares[0]:.1f} % face the sensor)",
           f"after: no orientation flag ({shares[1]:.1f} %)"])
    return shares


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cli", default="build/cli/nhnet-cli")
    ap.add_argument("--out", default=str(HERE))
    ap.add_argument("--method", default=None, help="--method for nhnet-cli (default: its own)")
    args = ap.parse_args()
    out_dir = Path(args.out)
    flags = ["--method", args.method] if args.method else []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        cam = vs.depth_camera("bull")
        depth_scan.write_pcd(work / "depth_camera.pcd", cam.points, cam.width, cam.height,
                             cam.position, cam.rotation)
        sensor = np.broadcast_to(cam.position, cam.points.shape)
        res = {"depth_camera": gallery_item(args.cli, work, out_dir, "depth_camera",
                                            work / "depth_camera.pcd", sensor,
                                            (cam.position + [0.25, 0.2, 0.3], (0, 0, 0)), flags)}
        stations = [vs.terrestrial((1.6, -1.2, 1.5), seed=2), vs.terrestrial((-1.8, 1.3, 1.4), seed=4)]
        vs.write_e57(work / "room.e57", stations)
        sensor = np.vstack([np.broadcast_to(s.position, s.points.shape) for s in stations])
        res["room"] = gallery_item(args.cli, work, out_dir, "room", work / "room.e57", sensor,
                                   ((2.9, -2.4, 2.9), (-1.0, 1.0, 0.6)), flags)
        air = vs.airborne()
        vs.write_las(work / "survey.las", air)
        centre = air.points.mean(axis=0)
        res["survey"] = gallery_item(args.cli, work, out_dir, "survey", work / "survey.las",
                                     np.array([0.0, 0.0, 1.0]),
                                     (centre + [-70, -120, 90], centre + [0, 10, -5]), flags)
    for name, (before, after) in res.items():
        print(f"{name}: facing the sensor, before {before:.2f} %, after {after:.2f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
