#!/usr/bin/env python3
"""Per-scan overhead of the Python binding over the C++ Localizer::process, for 32,768-point scans.

For each scan: the wall time of Localizer.process() seen from Python, minus the time the library's
Localizer::process took inside it (Result.timings["process_ms"], measured around that call alone). The difference
is what the binding adds: reading the numpy array, checking it, releasing and taking the GIL, the Result.
Prints one JSON object.

    PYTHONPATH=build/ci/python /usr/bin/python3 bench/python_overhead.py [--scans N] [--particles N] [--backend cpu]
"""
import argparse
import json
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python", "tests"))
import box_scene  # noqa: E402
import tsdf_mcl  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scans", type=int, default=60)
    ap.add_argument("--particles", type=int, default=2000)
    ap.add_argument("--backend", default="cpu")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        mesh = os.path.join(tmp, "room.ply")
        box_scene.write_mesh(mesh)
        room = tsdf_mcl.build_map_from_mesh(mesh, voxel_size=0.1)
    truth = box_scene.trajectory(args.scans)
    odom = box_scene.odometry(truth)
    rng = np.random.default_rng(1)
    dirs = box_scene.lidar_directions(64, 512)  # 32,768 rays
    scans = [box_scene.scan(t, dirs, rng)[:, :3].copy() for t in truth]
    loc = tsdf_mcl.Localizer(room, {"particles": args.particles, "max_particles": args.particles,
                                    "update_min_d": 0, "update_min_a": 0}, backend=args.backend)
    loc.init_pose(truth[0])
    stamps = 100.0 + 0.1 * np.arange(args.scans)
    call_ms, process_ms = [], []
    for points, o, stamp in zip(scans, odom, stamps):
        t0 = time.perf_counter()
        r = loc.process(points, o, stamp)
        call_ms.append(1e3 * (time.perf_counter() - t0))
        process_ms.append(r.timings["process_ms"])
    overhead = np.array(call_ms[3:]) - np.array(process_ms[3:])  # the first scans warm caches up
    print(json.dumps({
        "benchmark": "python_binding_overhead",
        "points_per_scan": int(scans[0].shape[0]),
        "scans_measured": int(overhead.size),
        "backend": loc.backend,
        "device": loc.device,
        "particles": args.particles,
        "python_call_ms_median": float(np.median(call_ms[3:])),
        "cpp_process_ms_median": float(np.median(process_ms[3:])),
        "overhead_ms_median": float(np.median(overhead)),
        "overhead_ms_p95": float(np.percentile(overhead, 95)),
        "overhead_ms_max": float(overhead.max()),
        "target_ms": 1.0,
        "converged_last": bool(r.converged),
    }, indent=2))


if __name__ == "__main__":
    main()
