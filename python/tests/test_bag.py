"""A ROS 1 bag reads as the same dataset as the folder the simulator writes beside it."""
import numpy as np
import pytest

import tsdf_mcl
from conftest import run

pytestmark = pytest.mark.skipif(not tsdf_mcl.bag_support, reason="built without ROS bag support (test_inputs "
                                "checks the error then)")


def test_bag_reads_like_its_folder(scene, cli, tmp_path):
    bag = tmp_path / "run.bag"
    run(cli, "simulate", "--scene", scene["mesh"], "--start", "2,3,0", "--length", "1", "--rate", "5", "--bag",
        str(bag), "-o", str(tmp_path / "folder"))
    folder = tsdf_mcl.read_dataset(str(tmp_path / "folder"))
    ds = tsdf_mcl.read_bag(str(bag), "/points", ground_truth_topic="/ground_truth", count=3)
    assert len(ds) == 3 and "/points" in ds.summary
    k = [list(folder.times).index(t) for t in ds.times]  # the bag may leave out a scan before the first odometry
    for (stamp, points, odom), i in zip(ds, k):
        f_stamp, f_points, f_odom = folder[i]
        assert stamp == f_stamp and np.array_equal(points, f_points)
        assert odom.shape == f_odom.shape == (4, 4)
    assert np.allclose(ds.poses, folder.poses[k], atol=1e-5)
    relative = [np.linalg.inv(o[0]) @ o[1] for o in (ds.odometry[:2], folder.odometry[k[:2]])]
    assert np.allclose(relative[0], relative[1], atol=1e-5)
    with pytest.raises(tsdf_mcl.Error, match="/no_such_topic"):
        tsdf_mcl.read_bag(str(bag), "/no_such_topic")
