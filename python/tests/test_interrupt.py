"""Ctrl-C in a long call: a KeyboardInterrupt between two ticks or steps, the work done kept.

Each test times a short call, sizes a long one to take about ten seconds at that pace, sends
this process SIGINT from a timer 0.3 s into it, then checks that it ended with
KeyboardInterrupt within a quarter of what it would have taken (Python's handler would raise
after an uninterrupted call too, but late), that the object counts the work it did, and that
going on from there gives the bits of a run that was never stopped.
"""

import os
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import tetradrill as td

PEN = Path(__file__).resolve().parents[2] / "tests/data/meshes/models/pen_tool_gmsh.mesh"


@pytest.fixture
def ctrl_c():
    """`ctrl_c(after)`: SIGINT to this process `after` seconds from now, Python's own
    handler (KeyboardInterrupt) in place; gives the time it was sent."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    sent = {}
    timers = []

    def arm(after):
        def fire():
            sent["at"] = time.perf_counter()
            os.kill(os.getpid(), signal.SIGINT)

        t = threading.Timer(after, fire)
        timers.append(t)
        t.start()
        return sent

    yield arm
    for t in timers:
        t.cancel()
        t.join()
    signal.signal(signal.SIGINT, previous)


def timed(call):
    """Seconds `call` takes."""
    t = time.perf_counter()
    call()
    return time.perf_counter() - t


LONG_S = 10.0


def units(short_s, short_units):
    """Units of work a call of about `LONG_S` seconds does, at the pace of `short_units` in
    `short_s` seconds."""
    return max(short_units, int(LONG_S / short_s * short_units))


def stopped(call, sent):
    """Runs `call`, sized to take about `LONG_S`, which must end in KeyboardInterrupt within a
    quarter of that after SIGINT."""
    with pytest.raises(KeyboardInterrupt):
        call()
    late = time.perf_counter() - sent["at"]
    assert late < 0.25 * LONG_S, f"the call went on {late:.2f} s after Ctrl-C"


def test_a_soft_run_stops_and_goes_on_to_the_same_bits(ctrl_c):
    def body():
        return td.SoftBody("builtin:block:6", young=5000.0, substeps=20, gravity=[0, 0, -9.81])

    n = units(timed(lambda: body().run(200, 0.004)), 200)
    b = body()
    b.fix_below([0, 0, -0.49], [0, 0, 1])
    stopped(lambda: b.run(n, 0.004), ctrl_c(0.3))
    k = b.steps
    assert 0 < k < n
    assert b.time == pytest.approx(k * 0.004)
    b.run(30, 0.004)

    fresh = body()
    fresh.fix_below([0, 0, -0.49], [0, 0, 1])
    fresh.run(k + 30, 0.004)
    assert np.abs(fresh.displacements).max() > 1e-4, "gravity moves the block"
    assert np.array_equal(b.displacements, fresh.displacements)
    assert np.array_equal(b.velocities, fresh.velocities)


def test_a_drilling_run_stops_between_ticks_and_goes_on_to_the_same_digest(ctrl_c):
    d = td.Drilling("builtin:block:8", "sphere:0.1", trace="wander:3")
    probe = td.Drilling("builtin:block:8", "sphere:0.1", trace="wander:3")
    poses, drill = d.trace_poses(2_000)
    n = units(timed(lambda: probe.run(poses, drill)), 2_000)
    poses, drill = d.trace_poses(n)
    stopped(lambda: d.run(poses, drill), ctrl_c(0.3))
    k = d.ticks
    assert 0 < k < len(poses)
    rest = d.run(poses[k : k + 500], drill[k : k + 500])

    fresh = td.Drilling("builtin:block:8", "sphere:0.1", trace="wander:3")
    whole = fresh.run(poses[: k + 500], drill[: k + 500])
    assert np.abs(whole).max() > 0, "the wander touches the block"
    assert np.array_equal(rest, whole[k:])
    assert d.ticks == fresh.ticks == k + 500
    assert d.force_digest == fresh.force_digest
    assert d.removed_volume == fresh.removed_volume


def test_replay_and_touching_stop_on_ctrl_c(ctrl_c):
    n = units(timed(lambda: td.replay(ticks=2_000, trace="wander:5")), 2_000)
    stopped(lambda: td.replay(ticks=n, trace="wander:5"), ctrl_c(0.3))

    t = td.Touching("builtin:block:6", PEN, max_force=1.0e6)
    pose = np.array([[0.01, 0.02, 0.45]])
    n = units(timed(lambda: t.run(np.repeat(pose, 4_000, axis=0))), 4_000)
    t.reset()
    # In the block, up and down: each tick's force depends on the last (the damping).
    z = 0.46 + 0.02 * np.sin(2 * np.pi * np.arange(n) / 500.0)
    poses = np.stack([np.full(n, 0.01), np.full(n, 0.02), z], axis=1)
    stopped(lambda: t.run(poses), ctrl_c(0.3))
    # The ticks run before the stop are kept: going on from there is a run never stopped.
    k = t.ticks
    assert 0 < k < n
    rest = t.run(poses[k : k + 300])
    fresh = td.Touching("builtin:block:6", PEN, max_force=1.0e6)
    assert np.array_equal(rest, fresh.run(poses[: k + 300])[k:])
    fresh.reset()
    assert not np.array_equal(rest, fresh.run(poses[k : k + 300])), "from rest it differs"
