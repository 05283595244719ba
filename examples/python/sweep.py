#!/usr/bin/env python3
"""A parameter sweep: sigma_hit x particles on one dataset, a table of the outcomes (tsdf-mcl evaluate's metrics).
Usage: sweep.py [MAP DATASET [SCANS]]  (default demo-out/office.tsdf demo-out/test, the first 120 scans)"""
import itertools
import sys
import time

import numpy as np
import tsdf_mcl

args = sys.argv[1:] + ["demo-out/office.tsdf", "demo-out/test", "120"][len(sys.argv) - 1:]
office = tsdf_mcl.Map.load(args[0])
data = tsdf_mcl.read_dataset(args[1], count=int(args[2]))
scans = list(data)  # read once, reused by every run

print("%9s %9s | %9s %12s %8s %8s %7s" % ("sigma_hit", "particles", "converged", "at scan", "ATE [m]", "false",
                                          "wall s"))
for sigma, particles in itertools.product([0.05, 0.1, 0.2], [10000, 30000]):
    t0 = time.perf_counter()
    loc = tsdf_mcl.Localizer(office, {"sigma_hit": sigma, "particles": particles, "seed": 1})
    results = [loc.process(points, odom, stamp) for stamp, points, odom in scans]
    wall = time.perf_counter() - t0
    m = tsdf_mcl.evaluate(data.times, np.stack([r.estimate for r in results]), data,
                          converged=[r.converged for r in results])
    at = m["convergence"]["scan"] if m["converged"] else "-"
    ate = "%.3f" % m["after_convergence"]["ate_rmse_m"] if m["converged"] else "-"
    print("%9.2f %9d | %9s %12s %8s %8d %7.1f" % (sigma, particles, m["converged"], at, ate,
                                                  m["false_convergence"]["false_claims"], wall))
