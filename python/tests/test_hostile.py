"""Hostile arguments (issue 52): no crash, one-line errors that name the argument, poses and odometry checked against
the map, paths as the system would read them, outputs that replace only regular files."""
import os
import pathlib
import time

import numpy as np
import pytest

import tsdf_mcl
from conftest import PARAMS

SMALL = dict(PARAMS, particles=300, max_particles=300, min_particles=100, init_candidates=2000, max_beams=64)


def one_line(excinfo):
    text = str(excinfo.value)
    assert "\n" not in text, text
    return text


@pytest.fixture(scope="module")
def scans(scene):
    return list(tsdf_mcl.read_dataset(scene["dataset"], count=3))


def test_no_crash_on_none_classes_and_self_containing_values(scene):
    with pytest.raises(TypeError, match="map must be a tsdf_mcl.Map .* not NoneType") as e:
        tsdf_mcl.Localizer(None)
    one_line(e)
    with pytest.raises(TypeError, match="not the class Map"):
        tsdf_mcl.Localizer(tsdf_mcl.Map)
    looped = []
    looped.append(looped)
    deep = []
    for _ in range(100000):
        deep = [deep]
    for value in (looped, deep, [[1.0, 2.0], [3.0]]):
        with pytest.raises(ValueError, match="init_height_band.*lists are not nested") as e:
            tsdf_mcl.Localizer(scene["map"], {"init_height_band": value})
        one_line(e)
    with pytest.raises(ValueError, match="must be a 1-D list of values, got an array of shape"):
        tsdf_mcl.Localizer(scene["map"], {"init": np.zeros((2, 3))})
    with pytest.raises(ValueError, match="a list of 1 items"):
        tsdf_mcl.Localizer(scene["map"], {"sigma_hit": [0.1]})
    with pytest.raises(ValueError, match="not complex"):
        tsdf_mcl.Localizer(scene["map"], {"sigma_hit": 0.1 + 1j})


def test_map_builders_check_as_build_map_does_at_once():
    points = np.random.default_rng(0).uniform(0.0, 5.0, (1000, 3)).astype(np.float32)
    start = time.monotonic()
    with pytest.raises(ValueError, match=r"voxel_size must be in 0.005..2 m, got 10") as e:
        tsdf_mcl.build_map_from_cloud(points, voxel_size=10, truncation=10000)
    one_line(e)
    with pytest.raises(ValueError, match=r"truncation must be in 0.1..6.4 m"):
        tsdf_mcl.build_map_from_cloud(points, voxel_size=0.1, truncation=10000)
    with pytest.raises(ValueError, match="margin must not be negative"):
        tsdf_mcl.build_map_from_cloud(points, voxel_size=0.1, truncation=0.3, margin=-1)
    with pytest.raises(ValueError, match="max_range must be positive"):
        tsdf_mcl.build_map_from_cloud(points, max_range=0)
    with pytest.raises(TypeError, match="fill_free_space must be True or False, not int"):
        tsdf_mcl.build_map_from_cloud(points, fill_free_space=1)
    assert time.monotonic() - start < 5.0  # refused before any work (it ran 23 s to a memory error)


@pytest.mark.parametrize("params, words", [
    ({"init": [1e300, 0, 0, 0, 0, 0]}, "the initial pose .* lies outside the map: x = 1e\\+300 m"),
    ({"init": [1e30, 3, 1, 0, 0, 0]}, "lies outside the map: x = 1e\\+30 m"),
    ({"init": "initial_pose", "initial_pose.x": 1e300}, "lies outside the map"),
    ({"init": [3, 3, 0.7, 0, 0, 0], "init_sigma_xy": 1e300}, "init_sigma_xy 1e\\+300 m is larger than the map's"),
    ({"motion_model": "diffusion", "diffusion_xy": 1e30}, "diffusion_xy"),
    ({"init_height_band": (0, 1e300)}, "init_height_band 1e\\+300 m lies beyond the map's height"),
    ({"alpha3": 1e30}, "alpha3 1e\\+30 is more than 10"),
])
def test_pose_parameters_beyond_the_map_are_refused(scene, params, words):
    with pytest.raises(ValueError, match=words) as e:
        tsdf_mcl.Localizer(scene["map"], dict(SMALL, **params))
    one_line(e)


def test_poses_and_odometry_beyond_the_map_are_refused_and_the_run_goes_on(scene, scans):
    loc = tsdf_mcl.Localizer(scene["map"], SMALL)
    truth = scene["truth"]
    far = truth[0].copy()
    far[0, 3] = 1e300
    with pytest.raises(ValueError, match="pose lies outside the map: x = 1e\\+300 m"):
        loc.init_pose(far)
    with pytest.raises(ValueError, match="covariance's sigma_xy 1e\\+150 m is larger than the map's diagonal"):
        loc.init_pose(truth[0], np.eye(6) * 1e300)
    with pytest.raises(ValueError, match="covariance's sigma_yaw must lie in"):
        loc.init_pose(truth[0], np.diag([0.1, 0.1, 0.1, 0.1, 0.1, 1e6]))
    loc.init_pose(truth[0], np.eye(6) * 0.01)
    (t0, p0, o0), (t1, p1, o1), (t2, p2, o2) = scans
    assert loc.process(p0, o0, t0).index == 0
    for shift, words in ((1e300, "odom lies beyond \\+-2\\^28 m"), (1e30, "odom lies beyond"),
                         (1e3, "odom moved 100[0-9.]* m since the scan before, more than the map's diagonal")):
        bad = o1.copy()
        bad[1, 3] += shift
        with pytest.raises(ValueError, match=words) as e:
            loc.process(p1, bad, t1)
        one_line(e)
    with pytest.raises(ValueError, match="stamp 1e\\+300 s lies beyond"):
        loc.process(p1, o1, 1e300)
    for stamp, points, odom in ((t1, p1, o1), (t2, p2, o2)):
        r = loc.process(points, odom, stamp)
        assert np.isfinite(r.estimate).all() and np.isfinite(r.covariance).all()
    assert loc.summary()["scans"] == 3
    assert np.linalg.norm(r.estimate[:3, 3] - truth[2][:3, 3]) < 0.5


def test_paths_are_read_as_the_system_reads_them(scene, tmp_path):
    yaml = tmp_path / "p.yaml"
    yaml.write_text("max_beams: 64\n")
    for call in (lambda: tsdf_mcl.Map.load(scene["map_file"] + "\0x"),
                 lambda: scene["map"].save(str(tmp_path / "m.tsdf") + "\0.bak"),
                 lambda: tsdf_mcl.read_dataset(scene["dataset"] + "\0x"),
                 lambda: tsdf_mcl.read_bag(str(tmp_path / "run.bag") + "\0x", "/points"),
                 lambda: tsdf_mcl.build_map_from_mesh(scene["mesh"] + "\0x"),
                 lambda: tsdf_mcl.Localizer(scene["map"], str(yaml) + "\0x")):
        with pytest.raises(ValueError, match="holds a NUL character") as e:
            call()
        one_line(e)
    assert not (tmp_path / "m.tsdf").exists()
    # os.PathLike wherever a path goes.
    loaded = tsdf_mcl.Map.load(pathlib.Path(scene["map_file"]))
    loaded.save(tmp_path / "copy.tsdf")
    assert (tmp_path / "copy.tsdf").read_bytes() == pathlib.Path(scene["map_file"]).read_bytes()
    assert len(tsdf_mcl.read_dataset(pathlib.Path(scene["dataset"]))) == 16
    assert tsdf_mcl.Localizer(loaded, yaml, backend="cpu").backend == "cpu"
    assert tsdf_mcl.build_map_from_mesh(pathlib.Path(scene["mesh"]), voxel_size=0.2).voxel_size == pytest.approx(0.2)
    with pytest.raises(TypeError, match="path must be a str or os.PathLike, not NoneType") as e:
        tsdf_mcl.Map.load(None)
    one_line(e)


def test_save_replaces_only_a_regular_file(scene, tmp_path):
    os.mkfifo(tmp_path / "fifo")
    os.symlink("/dev/full", tmp_path / "full")
    for name in ("fifo", "full"):
        with pytest.raises(tsdf_mcl.Error, match="is not a regular file") as e:
            scene["map"].save(tmp_path / name)
        one_line(e)
    assert pathlib.Path("/dev/full").is_char_device() and (tmp_path / "fifo").is_fifo()
    assert (tmp_path / "full").is_symlink()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fifo", "full"]  # no temporary left


def test_strict_types_and_one_line_errors(scene, scans):
    t0, p0, o0 = scans[0]
    loc = tsdf_mcl.Localizer(scene["map"], SMALL)
    cases = [
        (lambda: loc.process(p0, o0 + 1e-3j, t0), ValueError, "odom holds complex numbers"),
        (lambda: loc.process(p0, o0, "1.0"), TypeError, "stamp must be a real number, not str"),
        (lambda: loc.process(p0, o0, True), TypeError, "stamp must be a real number, not bool"),
        (lambda: loc.process(p0, o0, t0, scan_id=-1), ValueError, "scan_id must lie in 0.."),
        (lambda: loc.process(p0, o0, t0, scan_id=1.5), TypeError, "scan_id must be an int, not float"),
        (lambda: loc.process(p0, [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, None], [0, 0, 0, 1]], t0), ValueError,
         "odom must be a 4x4 rigid transform of real numbers, not a list of other objects"),
        (lambda: loc.add_imu(np.array([1.0, 0, 0, 9.81j])), ValueError, "imu samples holds complex numbers"),
        (lambda: tsdf_mcl.read_dataset(scene["dataset"], count=-1), ValueError, "count must lie in 0.."),
        (lambda: tsdf_mcl.read_dataset(scene["dataset"], start="1"), TypeError, "start must be an int, not str"),
        (lambda: tsdf_mcl.read_dataset(scene["dataset"])[2 ** 70], IndexError, "scan 1180591620717411303424 of 16"),
        (lambda: tsdf_mcl.read_dataset(scene["dataset"])[-2 ** 70], IndexError, "of 16"),
        (lambda: tsdf_mcl.read_dataset(scene["dataset"])["0"], TypeError, "indexed by an int, not str"),
        (lambda: scene["map"].distance(p0, interpolation=None), TypeError, "interpolation must be a str"),
        (lambda: tsdf_mcl.Localizer(scene["map"], SMALL, backend=3), TypeError, "backend must be a str, not int"),
        (lambda: tsdf_mcl.Localizer(scene["map"], {"a\nb": 1}), ValueError, "unknown parameter 'a\\\\nb'"),
        (lambda: tsdf_mcl.evaluate([t0], o0[None], tsdf_mcl.read_dataset(scene["dataset"]), converged=[None]),
         TypeError, r"converged\[0\] must be True or False, not NoneType"),
        (lambda: tsdf_mcl.evaluate([t0], o0[None], tsdf_mcl.read_dataset(scene["dataset"]), converged=[1]),
         TypeError, "must be True or False, not int"),
        (lambda: tsdf_mcl.evaluate([t0], o0[None], tsdf_mcl.read_dataset(scene["dataset"]),
                                   max_translation_error="0.3"), TypeError, "max_translation_error must be a real"),
    ]
    for call, kind, words in cases:
        with pytest.raises(kind, match=words) as e:
            call()
        one_line(e)
    flags = np.array([True])
    metrics = tsdf_mcl.evaluate([t0], o0[None], tsdf_mcl.read_dataset(scene["dataset"]), converged=flags)
    assert metrics["scans"] == 1


def test_library_errors_stay_one_line(tmp_path):
    name = tmp_path / "new\nline.tsdf"
    with pytest.raises(tsdf_mcl.Error, match="does not exist") as e:
        tsdf_mcl.Map.load(name)
    assert "new\\nline.tsdf" in one_line(e)
