"""Random arguments to every entry point of the module (hypothesis, Debian's python3-hypothesis): each call returns
or raises one of the module's exceptions (TypeError, ValueError, IndexError, tsdf_mcl.Error) with a one-line message,
and nothing crashes the interpreter. The sanitizer build runs this file under ASan + UBSan (python/CMakeLists.txt).

TSDF_MCL_HYPOTHESIS_EXAMPLES sets the examples per entry point (default 60)."""
import os
import pathlib
import tempfile

import numpy as np
import pytest

# hypothesis caches what it learns about unicode beside the working directory: keep the checkout clean.
os.environ.setdefault("HYPOTHESIS_STORAGE_DIRECTORY", os.path.join(tempfile.gettempdir(), "tsdf_mcl_hypothesis"))
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from hypothesis.extra import numpy as hnp  # noqa: E402

import tsdf_mcl
from conftest import PARAMS

EXAMPLES = int(os.environ.get("TSDF_MCL_HYPOTHESIS_EXAMPLES", "60"))
CHECKED = settings(max_examples=EXAMPLES, deadline=None, database=None, derandomize=True,
                   suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                          HealthCheck.data_too_large])
ALLOWED = (TypeError, ValueError, IndexError, tsdf_mcl.Error)
# Small runs: a random dict of parameters may name any of them, but not ten million particles on a shared machine.
SMALL = {"backend": "cpu", "cpu_threads": 1, "particles": 200, "max_particles": 200, "min_particles": 50,
         "init_candidates": 500, "max_beams": 32, "seed": 1}

scalars = st.one_of(
    st.none(), st.booleans(), st.integers(-2 ** 70, 2 ** 70), st.floats(allow_nan=True, allow_infinity=True),
    st.floats(-20.0, 20.0), st.complex_numbers(), st.text(max_size=6), st.binary(max_size=6),
    st.sampled_from(["nearest", "trilinear", "cpu", "global", "initial_pose", "1,2", "\0", "a\nb", "90deg"]))
values = st.recursive(scalars, lambda inner: st.lists(inner, max_size=7) | st.tuples(inner, inner), max_leaves=12)
arrays = hnp.arrays(dtype=st.sampled_from([np.float32, np.float64, np.int32, np.complex128, np.bool_, ">f4"]),
                    shape=hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=6))
transforms = st.one_of(arrays, hnp.arrays(np.float64, (4, 4), elements=st.floats(-1e3, 1e3)),
                       st.just(np.eye(4)), st.just(np.eye(4)[:3]))
anything = st.one_of(values, arrays, transforms, st.just(pathlib.Path("/nonexistent/x")), st.just(tsdf_mcl.Map))


def check(call):
    """Runs call(); an exception must be one of the module's, in one line."""
    try:
        call()
    except ALLOWED as e:
        assert "\n" not in str(e), repr(str(e))


@pytest.fixture(scope="module")
def localizer(scene):
    loc = tsdf_mcl.Localizer(scene["map"], dict(PARAMS, **SMALL))
    stamp, points, odom = tsdf_mcl.read_dataset(scene["dataset"])[0]
    loc.process(points, odom, stamp)
    return loc


@CHECKED
@given(st.lists(anything, max_size=4))
def test_map_entry_points(scene, args):
    m = scene["map"]
    check(lambda: tsdf_mcl.Map.load(*args[:1]))
    check(lambda: m.distance(*args[:2]))
    check(lambda: tsdf_mcl.read_dataset(*args))
    check(lambda: tsdf_mcl.read_dataset(scene["dataset"], *args[:3]))
    if args and not isinstance(args[0], (str, pathlib.Path)):
        check(lambda: m.save(args[0]))  # never a random path: it would be written


@CHECKED
@given(anything, st.lists(anything, max_size=6), st.sampled_from([1.0, 8.0, 64.0]))
def test_map_builders(scene, points, args, budget):
    check(lambda: tsdf_mcl.build_map_from_cloud(points, *args[:5], max_memory_mib=budget))
    check(lambda: tsdf_mcl.build_map_from_mesh(scene["mesh"], *args[:4], max_memory_mib=budget))
    check(lambda: tsdf_mcl.build_map_from_scans(points, *args[:6], max_memory_mib=budget))
    check(lambda: tsdf_mcl.build_map_from_cloud(np.float32([[0, 0, 0], [1, 1, 1]]), *args[:3], max_memory_mib=budget))


@CHECKED
@given(st.dictionaries(st.sampled_from([s["name"] for s in tsdf_mcl.parameter_specs()] + ["odom_alpha1", "x\0"]),
                       values, max_size=4),
       anything)
def test_localizer_parameters(scene, params, backend):
    check(lambda: tsdf_mcl.Localizer(scene["map"], dict(params, **SMALL)))
    check(lambda: tsdf_mcl.Localizer(scene["map"], params, backend))
    check(lambda: tsdf_mcl.Localizer(backend))


@CHECKED
@given(anything, anything, anything, anything)
def test_localizer_calls(scene, localizer, a, b, c, d):
    _, points, odom = tsdf_mcl.read_dataset(scene["dataset"])[1]
    check(lambda: localizer.process(a, b, c, d))
    check(lambda: localizer.process(points, a, b))
    check(lambda: localizer.process(points, odom, a, b))
    check(lambda: localizer.init_pose(a, b))
    check(lambda: localizer.init_pose(scene["truth"][1], a))
    check(lambda: localizer.add_imu(a))
    positions, orientations, weights = localizer.particles()
    assert np.isfinite(positions).all() and np.isfinite(orientations).all() and np.isfinite(weights).all()
    assert localizer.summary()["scans"] >= 1


@CHECKED
@given(st.lists(anything, max_size=8))
def test_dataset_and_evaluate(scene, args):
    ds = tsdf_mcl.read_dataset(scene["dataset"])
    check(lambda: ds[args[0]] if args else None)
    check(lambda: tsdf_mcl.evaluate(*args))
    check(lambda: tsdf_mcl.evaluate(ds.times, ds.poses, ds, *args[:6]))
    check(lambda: tsdf_mcl.read_bag(*args))
