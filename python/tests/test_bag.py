"""Bags read as the same dataset as the folder the simulator writes beside them: ROS 2 recordings (MCAP, SQLite3)
always, ROS 1 bags where the build has them; and the same run localizes alike from each."""
import numpy as np
import pytest

import tsdf_mcl
from conftest import PARAMS, run

ros1 = pytest.mark.skipif(not tsdf_mcl.ros1_bag_support, reason="built without ROS 1 bag support")


def simulate(scene, cli, tmp_path, bag):
    """The room's run (seed 1) as a folder and as `bag`; returns the folder."""
    folder = tmp_path / ("folder_" + bag.replace(".", "_"))
    run(cli, "simulate", "--scene", scene["mesh"], "--start", "2,3,0", "--length", "1", "--rate", "5", "--bag",
        str(tmp_path / bag), "-o", str(folder))
    return tsdf_mcl.read_dataset(str(folder))


def check_reads_like_its_folder(scene, cli, tmp_path, bag):
    folder = simulate(scene, cli, tmp_path, bag)
    ds = tsdf_mcl.read_bag(str(tmp_path / bag), "/points", ground_truth_topic="/ground_truth", count=3)
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
        tsdf_mcl.read_bag(str(tmp_path / bag), "/no_such_topic")


@pytest.mark.parametrize("bag", ["run.mcap", "run.db3", "run_folder"])
def test_ros2_bag_reads_like_its_folder(scene, cli, tmp_path, bag):
    check_reads_like_its_folder(scene, cli, tmp_path, bag)


@ros1
def test_ros1_bag_reads_like_its_folder(scene, cli, tmp_path):
    check_reads_like_its_folder(scene, cli, tmp_path, "run.bag")


def test_the_run_localizes_alike_from_every_bag(scene, cli, tmp_path):
    bags = ["run.mcap", "run.db3"] + (["run.bag"] if tsdf_mcl.ros1_bag_support else [])
    estimates = []
    for bag in bags:
        simulate(scene, cli, tmp_path, bag)
        loc = tsdf_mcl.Localizer(scene["map"], PARAMS)
        results = [loc.process(points, odom, stamp)
                   for stamp, points, odom in tsdf_mcl.read_bag(str(tmp_path / bag), "/points")]
        assert len(results) >= 4
        estimates.append(np.stack([r.estimate for r in results]))
    for bag, e in zip(bags[1:], estimates[1:]):
        assert np.array_equal(e, estimates[0]), bag
