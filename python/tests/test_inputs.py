"""Arrays of every layout the module reads in place, and one clear exception for every kind of bad input."""
import numpy as np
import pytest

import tsdf_mcl
from conftest import PARAMS

SMALL = dict(PARAMS, particles=300, max_particles=300, min_particles=100, init_candidates=2000, max_beams=64)


@pytest.fixture(scope="module")
def scan(scene):
    stamp, points, odom = tsdf_mcl.read_dataset(scene["dataset"])[0]
    return stamp, points, odom


def test_dataset_scans_are_numpy_views_of_the_library_buffer(scene):
    ds = tsdf_mcl.read_dataset(scene["dataset"], start=2, stride=3)
    assert len(ds) == 5 and list(ds.indices) == [2, 5, 8, 11, 14]
    assert np.array_equal(ds.times, scene["times"][2::3])
    assert np.allclose(ds.poses[0], scene["truth"][2], rtol=0, atol=1e-12)  # re-orthonormalized on reading
    stamp, points, odom = ds[-1]
    assert stamp == scene["times"][14] and odom.shape == (4, 4)
    assert points.dtype == np.float32 and points.shape == (5760, 3) and not points.flags.owndata
    raw = np.fromfile(scene["dataset"] + "/scans/000014.bin", np.float32).reshape(-1, 4)
    assert np.array_equal(points, raw[:, :3])
    assert sum(1 for _ in ds) == 5 and ds.imu.shape == (0, 4)


def test_point_layouts_accepted(scene, scan):
    _, points, _ = scan
    m = scene["map"]
    world = points + np.float32([3.0, 3.0, 0.7])
    expected = m.distance(np.ascontiguousarray(world))
    with_intensity = np.zeros((len(world), 4), np.float32)
    with_intensity[:, :3] = world
    doubled = np.repeat(world, 2, axis=0)
    for layout in (with_intensity, with_intensity[:, :3], np.asfortranarray(world), doubled[::2],
                   np.ascontiguousarray(world.T).T, world.copy(order="C").view()):
        assert np.array_equal(m.distance(layout), expected, equal_nan=True)
    readonly = world.copy()
    readonly.flags.writeable = False
    assert np.array_equal(m.distance(readonly), expected, equal_nan=True)
    assert m.distance(np.zeros((0, 3), np.float32)).shape == (0,)
    stamp, _, odom = scan
    loc = tsdf_mcl.Localizer(m, SMALL)
    for k, layout in enumerate((points, with_intensity - np.float32([3.0, 3.0, 0.7, 0.0]), np.asfortranarray(points))):
        assert loc.process(layout, odom, stamp + k).estimate.shape == (4, 4)
    # float32 and float64 transforms, C or Fortran order, lists.
    for k, t in enumerate((odom.astype(np.float32).astype(np.float64), np.asfortranarray(odom), odom.tolist())):
        assert loc.process(points, t, stamp + 3 + k).index == 3 + k


@pytest.mark.parametrize("bad, words", [
    (lambda p: p.astype(np.float64), "float32"),
    (lambda p: p.astype(np.int32), "float32"),
    (lambda p: p.astype(">f4"), "float32"),
    (lambda p: p[:, :2], "shape (N, 3) or (N, 4)"),
    (lambda p: np.zeros((len(p), 5), np.float32), "shape (N, 3) or (N, 4)"),
    (lambda p: p.reshape(-1), "shape (N, 3) or (N, 4)"),
    (lambda p: p[None], "shape (N, 3) or (N, 4)"),
    (lambda p: p[:0], "holds no point"),
    (lambda p: np.where(np.arange(len(p))[:, None] == 7, np.nan, p).astype(np.float32), "row 7 is not finite"),
    (lambda p: np.where(np.arange(len(p))[:, None] == 3, np.inf, p).astype(np.float32), "row 3 is not finite"),
])
def test_bad_points_raise_value_error(scene, scan, bad, words):
    stamp, points, odom = scan
    loc = tsdf_mcl.Localizer(scene["map"], SMALL)
    with pytest.raises(ValueError, match=words.replace("(", r"\(").replace(")", r"\)")):
        loc.process(bad(points), odom, stamp)


def test_points_must_be_an_array(scene, scan):
    stamp, points, odom = scan
    loc = tsdf_mcl.Localizer(scene["map"], SMALL)
    with pytest.raises(ValueError, match="numpy array"):
        loc.process(points.tolist(), odom, stamp)
    with pytest.raises(ValueError, match="numpy array"):
        scene["map"].distance("points")


def _scaled(t):
    t = t.copy()
    t[:3, :3] *= 2.0
    return t


def _sheared(t):
    t = t.copy()
    t[0, 1] += 0.2
    return t


def _last_row(t):
    t = t.copy()
    t[3, 0] = 1.0
    return t


def _mirrored(t):
    return t @ np.diag([1.0, 1.0, -1.0, 1.0])


@pytest.mark.parametrize("bad, words", [
    (_scaled, "not a rotation"), (_sheared, "not a rotation"), (_mirrored, "not a rotation"),
    (_last_row, "last row"), (lambda t: t[:3], "4x4"), (lambda t: np.full((4, 4), np.nan), "non-finite"),
    (lambda t: "identity", "4x4"),
])
def test_bad_transforms_raise_value_error(scene, scan, bad, words):
    stamp, points, odom = scan
    loc = tsdf_mcl.Localizer(scene["map"], SMALL)
    with pytest.raises(ValueError, match=words):
        loc.process(points, bad(odom), stamp)
    with pytest.raises(ValueError, match=words):
        loc.init_pose(bad(odom))


def test_other_bad_arguments(scene, scan, tmp_path):
    stamp, points, odom = scan
    loc = tsdf_mcl.Localizer(scene["map"], SMALL)
    with pytest.raises(ValueError, match="stamp"):
        loc.process(points, odom, float("nan"))
    with pytest.raises(ValueError, match="not symmetric"):
        loc.init_pose(odom, np.triu(np.ones((6, 6))))
    with pytest.raises(ValueError, match="negative variance"):
        loc.init_pose(odom, -np.eye(6))
    with pytest.raises(ValueError, match="6x6"):
        loc.init_pose(odom, np.eye(3))
    with pytest.raises(ValueError, match=r"\(M, 4\)"):
        loc.add_imu(np.zeros((3, 3)))
    loc.add_imu([10.0, 0.0, 0.0, 9.81])
    with pytest.raises(tsdf_mcl.Error, match="time order"):
        loc.add_imu(np.array([[5.0, 0.0, 0.0, 9.81]]))
    with pytest.raises(tsdf_mcl.Error, match="motion_model odometry"):
        loc.process(points, None, stamp)
    with pytest.raises(tsdf_mcl.Error, match="laser_min_range"):
        loc.process(np.zeros((10, 3), np.float32), odom, stamp)
    without_odometry = tsdf_mcl.Localizer(scene["map"], dict(SMALL, motion_model="constant_velocity"))
    assert without_odometry.process(points, None, stamp).index == 0
    with pytest.raises(ValueError, match="interpolation"):
        scene["map"].distance(points, interpolation="cubic")
    with pytest.raises(ValueError, match="voxel_size"):
        tsdf_mcl.build_map_from_mesh(scene["mesh"], voxel_size=0.0)
    with pytest.raises(ValueError, match="poses"):
        tsdf_mcl.build_map_from_scans([points], np.stack([odom, odom]))
    with pytest.raises(ValueError, match="stride"):
        tsdf_mcl.read_dataset(scene["dataset"], stride=0)
    with pytest.raises(IndexError):
        tsdf_mcl.read_dataset(scene["dataset"])[16]
    with pytest.raises(ValueError, match="ground_truth"):
        tsdf_mcl.evaluate([1.0], odom[None], "truth")
    with pytest.raises(ValueError, match="converged holds 2 flags"):
        tsdf_mcl.evaluate([1000.0], odom[None], tsdf_mcl.read_dataset(scene["dataset"]), converged=[True, False])


def test_bad_parameters_raise_value_error_naming_them(scene, tmp_path):
    with pytest.raises(ValueError, match="no_such_parameter"):
        tsdf_mcl.Localizer(scene["map"], {"no_such_parameter": 1})
    with pytest.raises(ValueError, match="did you mean sigma_hit"):
        tsdf_mcl.Localizer(scene["map"], {"sigma_hitt": 0.1})
    with pytest.raises(ValueError, match="sigma_hit"):
        tsdf_mcl.Localizer(scene["map"], {"sigma_hit": "wide"})
    with pytest.raises(ValueError, match="parameter 'particles' must be a number"):
        tsdf_mcl.Localizer(scene["map"], {"particles": {"a": 1}})
    # Flags as bools, amcl's names, angles with a unit: the schema's forms.
    assert tsdf_mcl.Localizer(scene["map"], dict(SMALL, ignore_imu=True, laser_sigma_hit=0.1,
                                                 update_min_a="5deg")).backend == "cpu"
    with pytest.raises(ValueError, match="sigma_hit"):
        tsdf_mcl.Localizer(scene["map"], {"sigma_hit": None})
    with pytest.raises(ValueError, match="backend"):
        tsdf_mcl.Localizer(scene["map"], SMALL, backend="quantum")
    with pytest.raises(ValueError, match="dict or the path"):
        tsdf_mcl.Localizer(scene["map"], 42)
    bad = tmp_path / "bad.yaml"
    bad.write_text("particles: [1, {a: 2}\n")
    with pytest.raises(tsdf_mcl.Error, match="bad.yaml"):
        tsdf_mcl.Localizer(scene["map"], str(bad))
    names = {s["name"] for s in tsdf_mcl.parameter_specs()}
    assert {"sigma_hit", "particles", "init_height_band", "backend", "seed"} <= names


def test_bad_files_raise_the_library_error(scene, tmp_path):
    with pytest.raises(tsdf_mcl.Error, match="missing.tsdf"):
        tsdf_mcl.Map.load(str(tmp_path / "missing.tsdf"))
    corrupt = tmp_path / "corrupt.tsdf"
    corrupt.write_bytes(open(scene["map_file"], "rb").read()[:100])
    with pytest.raises(tsdf_mcl.Error, match="corrupt.tsdf"):
        tsdf_mcl.Map.load(str(corrupt))
    with pytest.raises(tsdf_mcl.Error, match="nowhere"):
        tsdf_mcl.read_dataset(str(tmp_path / "nowhere"))
    with pytest.raises(tsdf_mcl.Error):
        tsdf_mcl.build_map_from_mesh(str(tmp_path / "none.ply"))
    with pytest.raises(tsdf_mcl.Error, match="x.bag does not exist"):
        tsdf_mcl.read_bag(str(tmp_path / "x.bag"), "/points")
