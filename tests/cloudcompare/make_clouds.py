#!/usr/bin/python3
"""Test clouds for the plugin tests (tests/cloudcompare, tests/meshlab), and a facing check.

    make_clouds.py big OUT.ply N            N points on a wavy 100 x 100 sheet, binary PLY
    make_clouds.py room OUT.ptx             one terrestrial scan from inside a closed room (PTX)
    make_clouds.py two_sided OUT.ptx        two scans of one plane, from above and from below
    make_clouds.py camera_ply OUT.ply       the room scan as a PLY with MeshLab's camera element
    make_clouds.py room_ply OUT.ply         the same points without the camera
    make_clouds.py facing PLY SPLIT X Y Z [X Y Z]  share of valid normals facing their sensor

The room scan: the sensor at ROOM_SENSOR inside the box ROOM_BOX; a point faces its sensor when
(sensor - p) . n > 0, i.e. inwards, where the MST orientation (no sensor known) turns the
normals of this closed surface outwards: the check tells the two apart. `facing` with two
sensors gives points [0, SPLIT) to the first and the rest to the second.
"""
import sys

import numpy as np

ROOM_BOX = (np.array([-3.0, -2.0, 0.0]), np.array([3.0, 2.0, 2.5]))
ROOM_SENSOR = np.array([0.5, -0.3, 1.2])


def write_ply(path, pts, camera=None):
    head = ["ply", "format binary_little_endian 1.0"]
    if camera is not None:
        head += ["element camera 1"] + [f"property float {n}" for n in CAMERA_FLOATS[:17]]
        head += ["property int viewportx", "property int viewporty"]
        head += [f"property float {n}" for n in CAMERA_FLOATS[17:]]
    head += [f"element vertex {len(pts)}", "property float x", "property float y",
             "property float z", "end_header"]
    with open(path, "wb") as f:
        f.write(("\n".join(head) + "\n").encode())
        if camera is not None:
            f.write(np.array(camera[:17], "<f4").tobytes())
            f.write(np.array([640, 480], "<i4").tobytes())
            f.write(np.array(camera[17:], "<f4").tobytes())
        f.write(np.ascontiguousarray(pts, "<f4").tobytes())


# MeshLab's PLY camera element (vcglib wrap/io_trimesh/import_ply.h), in its order.
CAMERA_FLOATS = ["view_px", "view_py", "view_pz", "x_axisx", "x_axisy", "x_axisz", "y_axisx",
                 "y_axisy", "y_axisz", "z_axisx", "z_axisy", "z_axisz", "focal", "scalex",
                 "scaley", "centerx", "centery", "k1", "k2", "k3", "k4"]


def big(path, n):
    rng = np.random.default_rng(1)
    u, v = 100 * rng.random(n), 100 * rng.random(n)
    write_ply(path, np.stack([u, v, 2 * np.sin(u / 7) * np.cos(v / 5)], 1))


def room_points():
    """Rays of a 90 x 180 (elevation x azimuth) sweep from ROOM_SENSOR to the room's walls."""
    el = np.radians(np.linspace(-80, 80, 90))[:, None]
    az = np.radians(np.arange(180) * 2.0)[None, :]
    d = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el) + 0 * az], -1)
    d = d.reshape(-1, 3)
    lo, hi = ROOM_BOX
    with np.errstate(divide="ignore"):
        t = np.where(d > 0, (hi - ROOM_SENSOR) / d, (lo - ROOM_SENSOR) / d)
    t = np.where(np.isfinite(t) & (t > 0), t, np.inf).min(1)
    return d * t[:, None]  # in the sensor's frame (axes of the room), sensor at the origin


def ptx_scan(f, rows, cols, sensor, local):
    f.write(f"{rows}\n{cols}\n")
    f.write("%.6f %.6f %.6f\n1 0 0\n0 1 0\n0 0 1\n" % tuple(sensor))
    f.write("1 0 0 0\n0 1 0 0\n0 0 1 0\n%.6f %.6f %.6f 1\n" % tuple(sensor))
    np.savetxt(f, np.hstack([local, np.full((len(local), 1), 0.5)]), fmt="%.6f")


def room(path):
    with open(path, "w") as f:
        ptx_scan(f, 90, 180, ROOM_SENSOR, room_points())


def two_sided(path):
    """A 4 x 4 plane at z = 0 scanned from (0, 0, 2) and, on a shifted grid, from (0, 0, -2)."""
    g = np.linspace(-2, 2, 80)
    x, y = np.meshgrid(g, g)
    plane = np.stack([x.ravel(), y.ravel(), 0 * x.ravel()], 1)
    with open(path, "w") as f:
        for sensor, shift in (((0, 0, 2.0), 0.0), ((0, 0, -2.0), 0.5 * (g[1] - g[0]))):
            ptx_scan(f, 80, 80, np.array(sensor), plane + [shift, shift, 0] - sensor)


def room_ply(path):
    write_ply(path, room_points() + ROOM_SENSOR)


def camera_ply(path):
    cam = [*ROOM_SENSOR, 1, 0, 0, 0, 1, 0, 0, 0, 1, 10.0, 0.01, 0.01, 320, 240, 0, 0, 0, 0]
    write_ply(path, room_points() + ROOM_SENSOR, camera=cam)


def facing(path, split, sensors):
    sys.path.insert(0, __file__.rsplit("/", 1)[0])
    from compare_normals import read
    p, n = read(path)
    s = np.where(np.arange(len(p))[:, None] < split, sensors[0], sensors[-1])
    valid = np.linalg.norm(n, axis=1) > 0.5
    share = float((((s - p) * n).sum(1)[valid] > 0).mean())
    print(f"{path}: {share * 100:.2f} % of {int(valid.sum())} valid normals face their sensor")
    return share


def main():
    cmd, path = sys.argv[1], sys.argv[2]
    if cmd == "big":
        big(path, int(sys.argv[3]))
    elif cmd in ("room", "two_sided", "camera_ply", "room_ply"):
        globals()[cmd](path)
    elif cmd == "facing":
        v = [float(x) for x in sys.argv[4:]]
        sensors = [np.array(v[i:i + 3]) for i in range(0, len(v), 3)]
        print(facing(path, int(sys.argv[3]), sensors))
    else:
        sys.exit(f"make_clouds.py: unknown command {cmd}")


if __name__ == "__main__":
    main()
