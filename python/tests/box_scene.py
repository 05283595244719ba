"""A small furnished room for the tests and the bench: its mesh, a LiDAR's scans by ray casting (numpy) and a
dataset folder in the layout of docs/architecture.md, so that the CLI and the Python module read the same input."""
import os

import numpy as np

ROOM = ((0.0, 0.0, 0.0), (10.0, 7.0, 3.0))  # seen from inside
FURNITURE = [  # (min corner, max corner): no two places alike
    ((1.0, 1.0, 0.0), (2.5, 1.8, 0.9)),
    ((6.0, 4.5, 0.0), (6.6, 6.8, 2.0)),
    ((8.0, 1.0, 0.0), (9.0, 2.0, 1.2)),
    ((3.5, 5.0, 0.0), (4.0, 5.5, 3.0)),
    ((0.0, 3.0, 0.0), (0.8, 4.5, 1.5)),
    ((5.0, 0.0, 0.0), (5.15, 2.5, 3.0)),
]
# Triangles of a box over its corners (bit 0: x, bit 1: y, bit 2: z at the max), counter-clockwise seen from outside.
_BOX_TRIANGLES = [(0, 4, 6), (0, 6, 2), (1, 3, 7), (1, 7, 5), (0, 1, 5), (0, 5, 4),
                  (2, 6, 7), (2, 7, 3), (0, 2, 3), (0, 3, 1), (4, 5, 7), (4, 7, 6)]


def write_mesh(path):
    """ASCII PLY of the room (normals inward: the outside is solid) and the furniture (normals outward)."""
    vertices, faces = [], []
    for k, (lo, hi) in enumerate([ROOM] + FURNITURE):
        base = len(vertices)
        vertices += [[hi[a] if i >> a & 1 else lo[a] for a in range(3)] for i in range(8)]
        faces += [(base + a, base + c, base + b) if k == 0 else (base + a, base + b, base + c)
                  for a, b, c in _BOX_TRIANGLES]
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
                "element face %d\nproperty list uchar int vertex_indices\nend_header\n" % (len(vertices), len(faces)))
        f.writelines("%g %g %g\n" % tuple(v) for v in vertices)
        f.writelines("3 %d %d %d\n" % t for t in faces)


def pose(x, y, z, yaw):
    c, s = np.cos(yaw), np.sin(yaw)
    t = np.eye(4)
    t[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    t[:3, 3] = (x, y, z)
    return t


def trajectory(n):
    """n poses (world_T_sensor) along the room at 0.7 m height, facing along the path."""
    s = np.linspace(0.0, 1.0, n)
    x, y = 2.0 + 6.0 * s, 3.0 + 0.6 * np.sin(2.0 * np.pi * s)
    yaw = np.arctan2(np.gradient(y), np.gradient(x))
    return [pose(x[i], y[i], 0.7, yaw[i]) for i in range(n)]


def lidar_directions(beams=16, azimuths=360):
    """Unit rays in the sensor frame: `beams` elevations in [-15, 15] deg by `azimuths` headings."""
    el = np.radians(np.linspace(-15.0, 15.0, beams))[:, None]
    az = np.linspace(0.0, 2.0 * np.pi, azimuths, endpoint=False)[None, :] + 1e-4
    d = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el) * np.ones_like(az)], -1)
    return d.reshape(-1, 3)


def _slabs(origin, dirs, lo, hi):
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (np.asarray(lo) - origin) / dirs
        t2 = (np.asarray(hi) - origin) / dirs
    return np.minimum(t1, t2).max(1), np.maximum(t1, t2).min(1)


def scan(world_T_sensor, dirs, rng, noise=0.01):
    """Ray-cast points (N, 4) float32 (x y z intensity) in the sensor frame."""
    origin = world_T_sensor[:3, 3]
    world_dirs = dirs @ world_T_sensor[:3, :3].T
    r = _slabs(origin, world_dirs, *ROOM)[1]
    for lo, hi in FURNITURE:
        near, far = _slabs(origin, world_dirs, lo, hi)
        hit = (near > 0.0) & (near <= far)
        r = np.where(hit, np.minimum(r, near), r)
    r = r + rng.normal(0.0, noise, r.shape)
    points = np.zeros((len(dirs), 4), np.float32)
    points[:, :3] = dirs * r[:, None]
    return points


def odometry(truth):
    """odom_T_sensor: the truth seen from an odometry frame elsewhere, with a small drift in yaw."""
    odom_T_world = pose(-3.0, 1.0, 0.0, 0.4)
    return [odom_T_world @ t @ pose(0.002 * i, 0.0, 0.0, 0.001 * i) for i, t in enumerate(truth)]


def _kitti(path, poses):
    with open(path, "w") as f:
        for p in poses:
            f.write(" ".join("%.17g" % v for v in p[:3, :].reshape(-1)) + "\n")


def write_dataset(folder, n=16, seed=3, beams=16, azimuths=360, t0=1000.0):
    """scans/NNNNNN.bin, times.txt, poses.txt (ground truth), odom.txt; returns (times, truth, odom)."""
    os.makedirs(os.path.join(folder, "scans"))
    rng = np.random.default_rng(seed)
    dirs = lidar_directions(beams, azimuths)
    truth = trajectory(n)
    odom = odometry(truth)
    times = t0 + 0.5 * np.arange(n)
    for i, t in enumerate(truth):
        scan(t, dirs, rng).tofile(os.path.join(folder, "scans", "%06d.bin" % i))
    with open(os.path.join(folder, "times.txt"), "w") as f:
        f.writelines("%.9f\n" % t for t in times)
    _kitti(os.path.join(folder, "poses.txt"), truth)
    _kitti(os.path.join(folder, "odom.txt"), odom)
    return times, truth, odom
