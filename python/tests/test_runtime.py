"""The module lets other Python threads run during long calls and leaks no references over many calls."""
import gc
import sys
import threading

import numpy as np

import tsdf_mcl
from conftest import PARAMS


def test_gil_is_released_during_process(scene):
    stamp, points, odom = tsdf_mcl.read_dataset(scene["dataset"])[0]
    # A global search over 200,000 hypotheses: long enough for the other thread to count.
    loc = tsdf_mcl.Localizer(scene["map"], dict(PARAMS, init_candidates=200000))
    started, stop = threading.Event(), threading.Event()
    counts = [0]

    def count():
        started.set()
        while not stop.is_set():
            counts[0] += 1

    worker = threading.Thread(target=count)
    worker.start()
    started.wait()
    before = counts[0]
    loc.process(points, odom, stamp)
    during = counts[0] - before
    stop.set()
    worker.join()
    assert during > 1000, "the counting thread stood still during process(): the GIL was held"


def test_no_reference_leak_over_1000_calls(scene):
    loc = tsdf_mcl.Localizer(scene["map"], dict(PARAMS, particles=200, max_particles=200, min_particles=100,
                                                init_candidates=1000, max_beams=32))
    stamp, points, odom = tsdf_mcl.read_dataset(scene["dataset"])[0]
    points = points[::20].copy()
    m = scene["map"]

    def calls(n):
        for k in range(n):
            r = loc.process(points, odom, stamp + 0.01 * k)
            r.estimate, r.covariance, r.hypotheses, r.timings, r.points
            m.distance(points)
            loc.particles()
        try:
            loc.process(points[:0], odom, stamp + n)
        except ValueError:
            pass

    calls(20)  # caches, first allocations
    gc.collect()
    refs = (sys.getrefcount(points), sys.getrefcount(odom), sys.getrefcount(loc), sys.getrefcount(m))
    objects = len(gc.get_objects())
    calls(1000)
    gc.collect()
    assert (sys.getrefcount(points), sys.getrefcount(odom), sys.getrefcount(loc), sys.getrefcount(m)) == refs
    assert len(gc.get_objects()) - objects < 50


def test_concurrent_calls_on_one_localizer_take_turns(scene):
    loc = tsdf_mcl.Localizer(scene["map"], dict(PARAMS, particles=500, max_particles=500, init_candidates=5000))
    scans = list(tsdf_mcl.read_dataset(scene["dataset"], count=6))
    errors = []

    def worker(part):
        try:
            for stamp, points, odom in part:
                loc.process(points, odom, stamp)
                loc.particles()
        except Exception as e:  # noqa: BLE001 (reported below)
            errors.append(e)

    # Out-of-order stamps from two threads are the caller's business; the localizer must stay whole.
    threads = [threading.Thread(target=worker, args=(scans[k::2],)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert loc.summary()["scans"] == 6
    positions, _, weights = loc.particles()
    assert np.isfinite(positions).all() and abs(weights.sum() - 1.0) < 1e-9
