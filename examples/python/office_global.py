#!/usr/bin/env python3
"""Global localization on the simulated office (tools/demo.sh writes demo-out/), trajectory and error plotted.
Usage: office_global.py [MAP DATASET [PLOT.png]]  (default demo-out/office.tsdf demo-out/test office_global.png)"""
import sys

import numpy as np
import tsdf_mcl

try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    sys.exit("office_global.py: matplotlib is missing (apt-get install python3-matplotlib)")

args = sys.argv[1:] + ["demo-out/office.tsdf", "demo-out/test", "office_global.png"][len(sys.argv) - 1:]
map_file, dataset, plot = args[:3]
loc = tsdf_mcl.Localizer(tsdf_mcl.Map.load(map_file), {"particles": 50000, "seed": 1})
data = tsdf_mcl.read_dataset(dataset)
results = [loc.process(points, odom, stamp) for stamp, points, odom in data]
estimate = np.stack([r.estimate for r in results])
m = tsdf_mcl.evaluate(data.times, estimate, data, converged=[r.converged for r in results])
print("converged:", m["converged"], "after convergence:", m["after_convergence"], "false claims:",
      m["false_convergence"]["false_claims"])
fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 9))
top.plot(data.poses[:, 0, 3], data.poses[:, 1, 3], "k-", label="ground truth")
top.plot(estimate[:, 0, 3], estimate[:, 1, 3], "r.", markersize=3, label="estimate")
top.set_aspect("equal"), top.legend(), top.set_xlabel("x [m]"), top.set_ylabel("y [m]")
bottom.semilogy(data.times - data.times[0], m["errors"]["translation_norm_m"]), bottom.set_xlabel("time [s]")
bottom.set_ylabel("translation error [m]")
fig.savefig(plot, dpi=100)
print("wrote", plot)
