"""Maps built by the module equal the CLI's; their lookup is the library's."""
import filecmp

import numpy as np

import tsdf_mcl
from conftest import run
import box_scene


def test_mesh_map_equals_the_cli_map(scene, cli, tmp_path):
    cli_map = tmp_path / "cli.tsdf"
    run(cli, "build-map", "--mesh", scene["mesh"], "--voxel", "0.1", "-o", str(cli_map))
    assert filecmp.cmp(cli_map, scene["map_file"], shallow=False)
    loaded = tsdf_mcl.Map.load(str(cli_map))
    rng = np.random.default_rng(1)
    points = rng.uniform((-1.0, -1.0, -0.5), (11.0, 8.0, 3.5), (20000, 3)).astype(np.float32)
    for mode in ("nearest", "trilinear"):
        assert np.array_equal(loaded.distance(points, mode), scene["map"].distance(points, mode), equal_nan=True)
    info = loaded.info()
    assert info["voxel_size"] == np.float32(0.1) and info["allocated_blocks"] > 0
    assert repr(loaded).startswith("<tsdf_mcl.Map voxel 0.100 m")


def test_lookup_matches_the_room(scene):
    m = scene["map"]
    # Points at known distances from the room's walls and floor, away from furniture.
    d = np.float32([0.05, 0.1, 0.2])
    near_floor = np.stack([np.full(3, 7.5), np.full(3, 3.5), d], 1).astype(np.float32)
    near_wall = np.stack([np.full(3, 7.5), 7.0 - d, np.full(3, 1.5)], 1).astype(np.float32)
    for pts in (near_floor, near_wall):
        assert np.abs(m.distance(pts, "trilinear") - d).max() < 0.03
    far = np.float32([[7.5, 3.5, 1.5]])
    assert abs(m.distance(far)[0] - m.truncation) < 1e-3  # free space beyond the band
    assert np.isnan(m.distance(np.float32([[50.0, 50.0, 50.0]])))[0]  # outside the map: unknown


def test_scan_and_cloud_builders(scene, cli, tmp_path):
    ds = tsdf_mcl.read_dataset(scene["dataset"], stride=4)
    from_dataset = tsdf_mcl.build_map_from_scans(ds, voxel_size=0.1)
    cli_map = tmp_path / "scans.tsdf"
    run(cli, "build-map", "--dataset", scene["dataset"], "--stride", "4", "--voxel", "0.1", "-o", str(cli_map))
    mine = tmp_path / "mine.tsdf"
    from_dataset.save(str(mine))
    assert filecmp.cmp(cli_map, mine, shallow=False)
    scans = [points for _, points, _ in ds]
    from_arrays = tsdf_mcl.build_map_from_scans(scans, ds.poses, voxel_size=0.1)
    probe = np.float32([[7.5, 3.5, 0.05], [7.5, 6.9, 1.5], [4.0, 3.0, 1.5]])
    assert np.allclose(from_arrays.distance(probe), from_dataset.distance(probe), atol=0.02, equal_nan=True)
    world = np.concatenate([p @ t[:3, :3].T.astype(np.float32) + t[:3, 3].astype(np.float32)
                            for p, t in zip(scans, ds.poses)])
    cloud_map = tsdf_mcl.build_map_from_cloud(world, voxel_size=0.1, trajectory=ds.poses[:, :3, 3])
    assert np.abs(cloud_map.distance(world[::50], "trilinear")).max() < 0.1  # the scanned surfaces
    assert cloud_map.info()["free_voxels"] > 0


def test_save_and_load_round_trip(scene, tmp_path):
    path = tmp_path / "copy.tsdf"
    scene["map"].save(str(path))
    assert filecmp.cmp(path, scene["map_file"], shallow=False)
    assert box_scene.ROOM[1][0] < tsdf_mcl.Map.load(str(path)).info()["world_max"][0]
