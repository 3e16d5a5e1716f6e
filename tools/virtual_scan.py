"""Virtual scanners: real-looking single-view scans of the CGAL demo meshes, with the sensor pose.

Three sensors, each a z-buffer over dense surface samples (the nearest sample per ray bin wins,
so hidden surfaces are really hidden), the ray's point placed at that depth with range noise:

- ``depth_camera``: a pinhole camera (organized W x H grid, NaN where no surface: a depth
  camera's PCD), noise growing with the square of the depth as in structured-light cameras;
- ``terrestrial``: a scanner station sweeping azimuth x elevation inside a room with a model in
  it (one E57 scan per station, the station's pose with it);
- ``airborne``: lines flown over a terrain with buildings, scanning across the track (a LAS
  survey in a projected frame: eastings near 500 000 m).

Used by docs/gallery/make_gallery.py and the tests; each scanner returns the points and the sensor
pose; write_e57 (pye57) and write_las (laspy) write them as a scanner's software would.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from depth_scan import quaternion
from nhnet_training.datagen import sample_surface
from nhnet_training.meshes import load_model


@dataclass
class Scan:
    points: np.ndarray  # (N, 3), NaN rows where a ray hit nothing (organized scans)
    position: np.ndarray  # (3,) sensor origin
    rotation: np.ndarray  # (3, 3) sensor axes as columns, in the points' frame
    width: int = 0  # organized grid width (0 = unorganized)
    height: int = 0


def model_samples(name: str, size: float, centre, n: int, rng) -> np.ndarray:
    """n surface samples of a demo mesh scaled so its largest extent is `size`, centred."""
    v, f = load_model(name)
    lo, hi = v.min(axis=0), v.max(axis=0)
    v = (v - (lo + hi) / 2) * (size / float((hi - lo).max()))
    pts, _, _ = sample_surface(v, f, n, rng)
    return pts + np.asarray(centre, dtype=float)


def look_at(position, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Camera axes as columns: x right, y down, z forward (the PCL / OpenCV convention)."""
    z = np.asarray(target, float) - np.asarray(position, float)
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def nearest_per_bin(bins: np.ndarray, depth: np.ndarray, n_bins: int) -> np.ndarray:
    """Depth of the nearest sample in each bin (inf where none)."""
    out = np.full(n_bins, np.inf)
    np.minimum.at(out, bins, depth)
    return out


def floor_samples(radius: float, height: float, n: int, rng) -> np.ndarray:
    """n samples of a horizontal disc (a floor under the model, ending where the camera's range does)."""
    r = radius * np.sqrt(rng.random(n))
    a = rng.random(n) * 2 * np.pi
    return np.column_stack([r * np.cos(a), r * np.sin(a), np.full(n, height)])


def depth_camera(model: str, width: int = 320, height: int = 240, distance: float = 1.2,
                 seed: int = 1) -> Scan:
    """An organized depth-camera scan of `model` (about 0.8 m tall) seen from `distance` m."""
    rng = np.random.default_rng(seed)
    samples = np.vstack([model_samples(model, 0.8, (0, 0, 0), 40 * width * height, rng),
                         floor_samples(1.0, -0.3, 20 * width * height, rng)])
    position = np.array([distance * 0.8, -distance * 0.6, 0.35])
    rot = look_at(position, (0, 0, 0))
    cam = (samples - position) @ rot  # camera coordinates
    f = 0.9 * width  # focal length in pixels (~58 degrees across, like a Kinect)
    z = cam[:, 2]
    u = np.floor(f * cam[:, 0] / z + width / 2).astype(np.int64)
    v = np.floor(f * cam[:, 1] / z + height / 2).astype(np.int64)
    ok = (z > 0) & (u >= 0) & (u < width) & (v >= 0) & (v < height)
    depth = nearest_per_bin(v[ok] * width + u[ok], z[ok], width * height)
    with np.errstate(invalid="ignore"):  # inf + noise where no surface
        depth += rng.normal(0, 1, depth.shape) * 0.0015 * depth**2  # structured light: ~z^2
    uu, vv = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    rays = np.column_stack([(uu.ravel() - width / 2) / f, (vv.ravel() - height / 2) / f,
                            np.ones(width * height)])
    depth[~np.isfinite(depth)] = np.nan
    pts = position + (rays * depth[:, None]) @ rot.T
    return Scan(pts, position, rot, width, height)


def room_samples(size, n: int, rng) -> np.ndarray:
    """n samples of the inside of a box room (floor, ceiling, four walls), origin at the floor centre."""
    sx, sy, sz = size
    faces = []  # (axis held fixed, its value, area)
    for axis, half, a, b in ((0, sx / 2, sy, sz), (1, sy / 2, sx, sz)):
        faces += [(axis, -half, a * b), (axis, half, a * b)]
    faces += [(2, 0.0, sx * sy), (2, sz, sx * sy)]
    areas = np.array([fc[2] for fc in faces])
    which = rng.choice(len(faces), n, p=areas / areas.sum())
    pts = rng.random((n, 3)) * np.array([sx, sy, sz]) - np.array([sx / 2, sy / 2, 0])
    for i, (axis, value, _) in enumerate(faces):
        pts[which == i, axis] = value
    return pts


def terrestrial(station, model: str | None = "bull", room=(6.0, 5.0, 3.0), az_steps: int = 480,
                el_steps: int = 160, seed: int = 2) -> Scan:
    """One station of a terrestrial scanner in a room with `model` (1.2 m; None: empty room)."""
    rng = np.random.default_rng(seed)
    n = 12 * az_steps * el_steps
    parts = [room_samples(room, n, rng)]
    if model:
        parts.append(model_samples(model, 1.2, (0.3, 0.2, 0.6), n // 3, rng))
    scene = np.vstack(parts)
    position = np.asarray(station, float)
    d = scene - position
    r = np.linalg.norm(d, axis=1)
    az = np.arctan2(d[:, 1], d[:, 0])
    el = np.arcsin(d[:, 2] / r)
    ia = np.floor((az + np.pi) / (2 * np.pi) * az_steps).astype(np.int64) % az_steps
    ie = np.floor((el + np.pi / 3) / (2 * np.pi / 3) * el_steps).astype(np.int64)
    ok = (ie >= 0) & (ie < el_steps)
    rng_bins = nearest_per_bin(ie[ok] * az_steps + ia[ok], r[ok], az_steps * el_steps)
    hit = np.isfinite(rng_bins)
    ie_c, ia_c = np.divmod(np.nonzero(hit)[0], az_steps)
    a = (ia_c + 0.5) / az_steps * 2 * np.pi - np.pi
    e = (ie_c + 0.5) / el_steps * (2 * np.pi / 3) - np.pi / 3
    rr = rng_bins[hit] + rng.normal(0, 0.002, hit.sum())  # 2 mm range noise
    dirs = np.column_stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    return Scan(position + dirs * rr[:, None], position, np.eye(3))


def terrain_height(x, y):
    """Rolling ground (metres) with two flat-roofed buildings."""
    z = 2.0 * np.sin(x / 23.0) + 1.5 * np.cos(y / 17.0)
    for cx, cy, w, d, h in ((40, 50, 20, 14, 9), (110, 120, 26, 18, 14)):
        z = np.where((np.abs(x - cx) < w / 2) & (np.abs(y - cy) < d / 2), h, z)
    return z


def first_return(x0: float, altitude: float, tan_angle: np.ndarray, y: np.ndarray,
                 top: float = 20.0, bottom: float = -6.0, step: float = 0.02) -> np.ndarray:
    """Height where each slanted ray (x = x0 + (altitude - z) tan_angle) first meets the
    ground, marched down from `top` (above every roof) in `step` m."""
    z = np.full(y.shape, np.nan)
    for zz in np.arange(top, bottom, -step):
        hit = np.isnan(z) & (zz <= terrain_height(x0 + (altitude - zz) * tan_angle, y))
        z[hit] = zz
    return z


def airborne(extent: float = 160.0, altitude: float = 300.0, spacing: float = 0.5,
             half_angle: float = np.radians(20), seed: int = 3,
             origin=(500000.0, 4200000.0, 100.0)) -> Scan:
    """Lines flown along y at `altitude` over terrain_height, each shot across the track at up
    to +-half_angle; points in a projected frame (`origin` added: eastings near 500 km)."""
    rng = np.random.default_rng(seed)
    ys = (np.arange(int(extent / spacing)) + 0.5) * spacing
    x0 = extent / 2
    n_shots = int(2 * altitude * np.tan(half_angle) / spacing)
    tan_angle, y = np.meshgrid(np.tan(np.linspace(-half_angle, half_angle, n_shots)), ys)
    z = first_return(x0, altitude, tan_angle.ravel(), y.ravel())
    pts = np.column_stack([x0 + (altitude - z) * tan_angle.ravel(), y.ravel(), z])
    pts += rng.normal(0, 0.03, pts.shape)  # 3 cm
    keep = (pts[:, 0] >= 0) & (pts[:, 0] <= extent) & np.isfinite(z)
    return Scan(pts[keep] + np.asarray(origin), np.asarray(origin) + [x0, 0, altitude], np.eye(3))


def write_e57(path: Path, scans: list[Scan]) -> None:
    """One E57 scan per station, points in the station's own frame, its pose beside them."""
    import pye57
    e57 = pye57.E57(str(path), mode="w")
    for scan in scans:
        local = (scan.points - scan.position) @ scan.rotation  # station frame
        data = {"cartesianX": local[:, 0], "cartesianY": local[:, 1], "cartesianZ": local[:, 2]}
        e57.write_scan_raw(data, rotation=np.array(quaternion(scan.rotation)),
                           translation=scan.position)
    e57.close()


def write_las(path: Path, scan: Scan) -> None:
    """LAS 1.4 point format 6 in a projected frame (mm scale), with intensity and GPS time."""
    import laspy
    header = laspy.LasHeader(point_format=6, version="1.4")
    header.scales = np.array([0.001, 0.001, 0.001])
    header.offsets = np.floor(scan.points.min(axis=0))
    las = laspy.LasData(header)
    las.x, las.y, las.z = scan.points[:, 0], scan.points[:, 1], scan.points[:, 2]
    las.intensity = np.full(len(scan.points), 1000, dtype=np.uint16)
    las.gps_time = np.arange(len(scan.points)) * 1e-5
    las.classification = np.full(len(scan.points), 2, dtype=np.uint8)
    las.write(str(path))
