#!/usr/bin/env python3
"""Organized single-view depth-camera scans of an analytic scene, for the default orientation
(--orient auto, core/include/nhnet/orient/auto.hpp) and the gallery.

A virtual pinhole camera (PCL's convention: x right, y down, z forward) casts one ray per pixel
at a scene of a sphere, a cube, a floor and a wall; pixels whose ray misses everything are NaN
(about 30 % of the image, as the background of a real depth camera). Depth noise is Gaussian
along the ray, sigma = noise x depth^2 (structured-light sensors grow with depth squared).

Writes the scan as an organized binary PCD (WIDTH x HEIGHT, VIEWPOINT = the camera's pose) and as
a binary PLY with PCL's camera element (view_p*, axes, viewport = the grid), the two conventions
nhnet reads a sensor from (docs/formats.md#sensors). With --pose the camera is moved and turned
and the points are written in the world frame, so the sensor is not at the origin. numpy only.

    /usr/bin/python3 tools/depth_scan.py out/scan --width 320 --height 240
    /usr/bin/python3 tools/depth_scan.py out/moved --pose   # sensor away from the origin

Also usable as a module: scan(...) returns (points (H*W, 3) with NaN rows, position, rotation).
"""

import argparse
import struct
from pathlib import Path

import numpy as np

# The scene in the camera's default frame (camera at the origin looking down +z, y down).
SPHERE = (np.array([0.35, 0.05, 2.6]), 0.55)           # centre, radius
CUBE = (np.array([-0.75, -0.05, 3.1]), 0.45)           # centre, half edge (axis-aligned)
FLOOR = (1, 0.7, (-3.0, 3.0), (1.0, 8.0))              # y = 0.7, x range, z range
WALL = (2, 5.0, (-2.2, 2.2), (-1.2, 0.7))              # z = 5, x range, y range


def _rotation(yaw, pitch):
    """Rotation (columns = camera axes in the world) for a yaw about y then a pitch about x."""
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rx = np.array([[1, 0, 0], [0, cp, -sp], [0, sp, cp]])
    return ry @ rx


def _hit_sphere(d, c, r):
    b = d @ c
    disc = b * b - (c @ c - r * r)
    t = b - np.sqrt(np.where(disc >= 0, disc, np.nan))
    return np.where((disc >= 0) & (t > 0), t, np.inf)


def _hit_cube(d, c, h):
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (c - h) / d
        t2 = (c + h) / d
    near = np.nanmax(np.minimum(t1, t2), axis=1)
    far = np.nanmin(np.maximum(t1, t2), axis=1)
    return np.where((near <= far) & (near > 0), near, np.inf)


def _hit_rectangle(d, rect):
    """An axis-aligned rectangle: coordinate `axis` = at, the two other ranges in order."""
    axis, at, (a0, a1), (b0, b1) = rect
    u, w = [k for k in range(3) if k != axis]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = at / d[:, axis]
    p = d * t[:, None]
    ok = (t > 0) & (p[:, u] >= a0) & (p[:, u] <= a1) & (p[:, w] >= b0) & (p[:, w] <= b1)
    return np.where(ok, t, np.inf)


def scan(width=320, height=240, fov_deg=58.0, noise=0.001, pose=False, seed=0):
    """Points (height*width, 3) row-major with NaN rows for the background, the sensor's
    position (3,) and rotation (3, 3; columns = camera axes in the points' frame)."""
    f = 0.5 * width / np.tan(np.radians(fov_deg) / 2)
    u, v = np.meshgrid(np.arange(width) + 0.5 - width / 2, np.arange(height) + 0.5 - height / 2)
    d = np.c_[u.ravel() / f, v.ravel() / f, np.ones(u.size)]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t = np.minimum.reduce([_hit_sphere(d, *SPHERE), _hit_cube(d, *CUBE),
                           _hit_rectangle(d, FLOOR), _hit_rectangle(d, WALL)])
    rng = np.random.default_rng(seed)
    hit = np.isfinite(t)
    t = np.where(hit, t + rng.normal(size=t.size) * noise * np.where(hit, t * t, 0), np.nan)
    pts = d * t[:, None]
    position, rotation = np.zeros(3), np.eye(3)
    if pose:  # the same view from a camera moved and turned in the world
        position, rotation = np.array([0.8, -0.4, -1.5]), _rotation(0.35, -0.2)
        pts = pts @ rotation.T + position
    return pts, position, rotation


def quaternion(r):
    """(w, x, y, z) of a rotation matrix."""
    w = np.sqrt(max(0.0, 1 + np.trace(r))) / 2
    if w > 1e-6:
        return np.array([w, (r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w),
                         (r[1, 0] - r[0, 1]) / (4 * w)])
    raise ValueError("rotation of 180 degrees: not needed here")


def write_pcd(path, pts, width, height, position, rotation):
    """Organized binary PCD with the sensor as VIEWPOINT."""
    vp = " ".join(f"{x:.9g}" for x in np.r_[position, quaternion(rotation)])
    header = (f"# .PCD v0.7 - depth_scan.py\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
              f"COUNT 1 1 1\nWIDTH {width}\nHEIGHT {height}\nVIEWPOINT {vp}\n"
              f"POINTS {width * height}\nDATA binary\n")
    Path(path).write_bytes(header.encode() + pts.astype("<f4").tobytes())


def write_ply(path, pts, width, height, position, rotation):
    """Binary PLY with PCL's camera element (view_p*, the rotation's rows as PCL writes them,
    viewport = the grid)."""
    props = ["view_px", "view_py", "view_pz"] + [f"{a}_axis{c}" for a in "xyz" for c in "xyz"]
    props += ["focal", "scalex", "scaley", "centerx", "centery"]
    header = ("ply\nformat binary_little_endian 1.0\ncomment depth_scan.py\n"
              f"element vertex {len(pts)}\nproperty float x\nproperty float y\nproperty float z\n"
              "element camera 1\n" + "".join(f"property float {p}\n" for p in props) +
              "property int viewportx\nproperty int viewporty\nproperty float k1\n"
              "property float k2\nend_header\n")
    cam = struct.pack("<17f", *position, *rotation.ravel(), 0, 0, 0, 0, 0)
    cam += struct.pack("<2i2f", width, height, 0, 0)
    Path(path).write_bytes(header.encode() + pts.astype("<f4").tobytes() + cam)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", help="output stem: writes OUT.pcd and OUT.ply")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=480)
    ap.add_argument("--noise", type=float, default=0.001, help="depth noise / depth^2")
    ap.add_argument("--pose", action="store_true", help="move the sensor away from the origin")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    pts, pos, rot = scan(a.width, a.height, noise=a.noise, pose=a.pose, seed=a.seed)
    write_pcd(a.out + ".pcd", pts, a.width, a.height, pos, rot)
    write_ply(a.out + ".ply", pts, a.width, a.height, pos, rot)
    nan = np.isnan(pts[:, 0]).mean()
    print(f"{a.out}.pcd/.ply: {a.width}x{a.height}, {100 * nan:.1f} % NaN, sensor at {pos}")


if __name__ == "__main__":
    main()
