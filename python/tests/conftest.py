"""Session fixtures: the furnished room's mesh, its map (built once, by the module) and a 16-scan dataset."""
import os
import subprocess

import pytest

import box_scene
import tsdf_mcl  # from the build tree: ctest sets PYTHONPATH

# A ground robot's run on the CPU backend with fixed threads: reproducible for a seed (docs/python.md).
PARAMS = {
    "backend": "cpu", "cpu_threads": 2, "seed": 5, "particles": 4000, "max_particles": 4000, "min_particles": 300,
    "init_candidates": 40000, "init_max_tilt": 0.1, "init_height_band": (0.4, 1.0), "max_beams": 256,
    "update_min_d": 0.0, "update_min_a": 0.0,
}


def cli_args(params):
    """The same parameters as tsdf-mcl localize flags."""
    args = []
    for k, v in params.items():
        args += ["--" + k, ",".join(map(str, v)) if isinstance(v, tuple) else str(v)]
    return args


@pytest.fixture(scope="session")
def cli():
    path = os.environ.get("TSDF_MCL_CLI")
    if not path or not os.path.exists(path):
        pytest.fail("TSDF_MCL_CLI must name the tsdf-mcl program (ctest sets it)")
    return path


def run(cli_path, *args):
    r = subprocess.run([cli_path, *args], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return r


@pytest.fixture(scope="session")
def scene(tmp_path_factory):
    d = tmp_path_factory.mktemp("room")
    mesh = str(d / "room.ply")
    box_scene.write_mesh(mesh)
    times, truth, odom = box_scene.write_dataset(str(d / "dataset"))
    room_map = tsdf_mcl.build_map_from_mesh(mesh, voxel_size=0.1)
    map_file = str(d / "room.tsdf")
    room_map.save(map_file)
    return {"dir": d, "mesh": mesh, "map": room_map, "map_file": map_file, "dataset": str(d / "dataset"),
            "times": times, "truth": truth, "odom": odom}
