"""The module lets other Python threads run during long calls and leaks no references over many calls."""
import gc
import sys
import threading
import time
import tracemalloc

import numpy as np

import tsdf_mcl
from conftest import PARAMS


def test_gil_is_released_during_process(scene):
    stamp, points, odom = tsdf_mcl.read_dataset(scene["dataset"])[0]
    # A global search over 200,000 hypotheses on one core, while the other thread counts on the other.
    params = dict(PARAMS, init_candidates=200000, cpu_threads=1)
    warmed_up, stop = threading.Event(), threading.Event()
    counts = [0]

    def count():
        while not stop.is_set():
            counts[0] += 1
            if counts[0] == 100000:
                warmed_up.set()

    worker = threading.Thread(target=count)
    t0 = time.perf_counter()
    worker.start()
    warmed_up.wait()  # the GIL is free here: the counter's own pace
    rate = 100000 / (time.perf_counter() - t0)
    # Searches (each on a fresh localizer) until they have taken half a second together: one took 0.19 s on a fast
    # machine, too short to tell a held GIL from a released one.
    during = seconds = 0
    while seconds < 0.5:
        loc = tsdf_mcl.Localizer(scene["map"], params)
        before, t1 = counts[0], time.perf_counter()
        loc.process(points, odom, stamp)
        during, seconds = during + counts[0] - before, seconds + time.perf_counter() - t1
    stop.set()
    worker.join()
    # Holding the GIL, the counter would get at most a switch interval (5 ms) at either end of each call.
    assert during > 0.1 * rate * seconds, "the counting thread stood still during process(): the GIL was held"


def test_no_reference_leak_over_1000_calls(scene):
    # The motion gate holds most scans (an update per roughening_interval): the binding's work is what repeats.
    loc = tsdf_mcl.Localizer(scene["map"], dict(PARAMS, particles=200, max_particles=200, min_particles=100,
                                                init_candidates=1000, max_beams=32, update_min_d=1e3,
                                                update_min_a=3.0))
    stamp, points, odom = tsdf_mcl.read_dataset(scene["dataset"])[0]
    points = points[::20].copy()
    m = scene["map"]

    def calls(n):
        for k in range(n):
            r = loc.process(points, odom, stamp + 0.01 * k)
            r.estimate, r.covariance, r.places, r.timings, r.points
            m.distance(points)
            loc.particles()
        try:
            loc.process(points[:0], odom, stamp + n)
        except ValueError:
            pass

    calls(20)  # caches, first allocations
    gc.collect()
    tracemalloc.start()
    refs = (sys.getrefcount(points), sys.getrefcount(odom), sys.getrefcount(loc), sys.getrefcount(m))
    objects = len(gc.get_objects())
    memory = tracemalloc.get_traced_memory()[0]
    calls(1000)
    gc.collect()
    grown = tracemalloc.get_traced_memory()[0] - memory
    tracemalloc.stop()
    assert (sys.getrefcount(points), sys.getrefcount(odom), sys.getrefcount(loc), sys.getrefcount(m)) == refs
    assert len(gc.get_objects()) - objects < 50
    # numpy reports its buffers to tracemalloc: one array or Result kept per call would add over 100 kB.
    assert grown < 50000, grown


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
