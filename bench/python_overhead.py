#!/usr/bin/env python3
"""Per-scan overhead of the Python binding over the C++ Localizer::process, for 32,768-point scans.

For each scan: the wall time of Localizer.process() seen from Python, minus the time the library's
Localizer::process took inside it (Result.timings["process_ms"], measured around that call alone). The difference
is what the binding adds: reading the numpy array, checking it, releasing and taking the GIL, the Result.
With --cli, also the same global localization run both ways on a dataset of such scans: `tsdf-mcl localize`'s
loop (report.json summary.wall_s: reading the scans and processing them) against the same loop in Python
(read_dataset and Localizer.process), same parameters and seed. Prints one JSON object.

    PYTHONPATH=build/ci/python /usr/bin/python3 bench/python_overhead.py [--scans N] [--particles N] [--backend cpu]
        [--cli build/ci/tools/tsdf-mcl]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "python", "tests"))
import box_scene  # noqa: E402
import tsdf_mcl  # noqa: E402


def compare_with_cli(cli, room_file, room, params, scans, tmp):
    """Wall time of the localization loop: the CLI's against Python's, same dataset, parameters and seed."""
    dataset = os.path.join(tmp, "dataset")
    box_scene.write_dataset(dataset, n=scans, beams=64, azimuths=512)
    flags = [a for k, v in params.items() for a in ("--" + k, str(v))]
    out = os.path.join(tmp, "run")
    subprocess.run([cli, "localize", "--map", room_file, "--dataset", dataset, *flags, "-o", out], check=True,
                   capture_output=True)
    with open(os.path.join(out, "report.json")) as f:
        cli_s = json.load(f)["summary"]["wall_s"]
    loc = tsdf_mcl.Localizer(room, params)
    t0 = time.perf_counter()
    for stamp, points, odom in tsdf_mcl.read_dataset(dataset):
        loc.process(points, odom, stamp)
    python_s = time.perf_counter() - t0
    return {"scans": scans, "cli_loop_s": cli_s, "python_loop_s": python_s, "python_over_cli": python_s / cli_s}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scans", type=int, default=60)
    ap.add_argument("--particles", type=int, default=2000)
    ap.add_argument("--backend", default="cpu")
    ap.add_argument("--cli", help="the tsdf-mcl program: also compare a whole run with localize")
    args = ap.parse_args()
    compared = None
    with tempfile.TemporaryDirectory() as tmp:
        mesh = os.path.join(tmp, "room.ply")
        box_scene.write_mesh(mesh)
        room = tsdf_mcl.build_map_from_mesh(mesh, voxel_size=0.1)
        if args.cli:
            room_file = os.path.join(tmp, "room.tsdf")
            room.save(room_file)
            params = {"backend": args.backend, "seed": 1, "particles": 20000, "max_particles": 20000,
                      "init_height_band": "0.4,1.0", "init_max_tilt": 0.1}
            compared = compare_with_cli(args.cli, room_file, room, params, 40, tmp)
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
        "whole_run": compared,
    }, indent=2))


if __name__ == "__main__":
    main()
