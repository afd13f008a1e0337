"""Long runs release the GIL: another Python thread keeps going while they work."""

import threading
import time

import tetradrill as td


def progress_during(work):
    """Runs `work` in a thread while this one counts; the longest pause of the counting
    inside the work's own window, and the window's length."""
    window = {}
    stamps = []
    done = threading.Event()

    def worker():
        window["t0"] = time.perf_counter()
        work()
        window["t1"] = time.perf_counter()
        done.set()

    t = threading.Thread(target=worker)
    t.start()
    while not done.is_set():
        stamps.append(time.perf_counter())
    t.join()
    t0, t1 = window["t0"], window["t1"]
    inside = [t0] + [s for s in stamps if t0 < s < t1] + [t1]
    gaps = [b - a for a, b in zip(inside, inside[1:])]
    return max(gaps), t1 - t0


def test_drilling_run_releases_the_gil():
    d = td.Drilling("builtin:block:8", "sphere:0.1", trace="wander:3")
    poses, drill = d.trace_poses(20_000)
    gap, span = progress_during(lambda: d.run(poses, drill))
    assert d.ticks == 20_000
    assert span > 0.2, f"the run took {span:.3f} s: too short to tell"
    # Holding the GIL, the counting would stop for the whole run.
    assert gap < 0.25 * span, f"the other thread stalled {gap:.3f} s of {span:.3f} s"


def test_soft_body_run_releases_the_gil():
    b = td.SoftBody("builtin:block:6", young=5000.0, substeps=20)
    gap, span = progress_during(lambda: b.run(400, 0.004))
    assert b.steps == 400
    assert span > 0.2, f"the run took {span:.3f} s: too short to tell"
    assert gap < 0.25 * span, f"the other thread stalled {gap:.3f} s of {span:.3f} s"
