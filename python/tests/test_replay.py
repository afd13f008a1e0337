"""Replays and drilling runs against `tetradrill replay --json` run as a subprocess: the
command line's own loop over the same scenario is the oracle (removed volume by region to
1e-12 relative, the same force digest)."""

import math

import numpy as np
import pytest

import tetradrill as td


def close(a, b, rel=1e-12):
    return abs(a - b) <= rel * max(abs(a), abs(b)) + 1e-300


def same_regions(ours, theirs):
    """`ours` {int: float} against the JSON's {"label": float}."""
    assert sorted(str(k) for k in ours) == sorted(theirs), (ours, theirs)
    for k, v in ours.items():
        assert close(v, theirs[str(k)]), (k, v, theirs[str(k)])


@pytest.mark.parametrize(
    "scenario, ticks",
    [("builtin:firmware-tooth", None), ("builtin:firmware-regions", 3000), ("builtin:demo", 2500)],
)
def test_replay_matches_the_command_line(cli, tmp_path, scenario, ticks):
    args = ["--scenario", scenario] + ([] if ticks is None else ["--ticks", str(ticks)])
    want = cli(args, tmp_path)
    got = td.replay(scenario, ticks=ticks)
    assert got["ticks"] == want["ticks"]
    assert got["force_digest"] == want["force_digest"]
    same_regions(got["removed_by_region"], want["removed_by_region"])
    assert close(got["removed_volume"], want["removed_volume"])
    assert close(got["initial_volume"], want["initial_volume"])
    # The JSON's max force is an f32 printed in decimal.
    assert got["max_force"] == pytest.approx(want["force"]["max_n"], rel=1e-6)
    assert got["contact_ticks"] == want["force"]["contact_ticks"]
    assert got["forces"].shape == (want["ticks"], 3)
    assert sum(got["removed_by_region"].values()) == pytest.approx(got["removed_volume"], rel=1e-9)
    # Every region of the tooth lost material.
    if scenario == "builtin:firmware-tooth":
        assert set(got["removed_by_region"]) == {1, 2, 3}
        assert all(v > 0 for v in got["removed_by_region"].values())


def write_trace(path, poses, drill):
    """A trace CSV, one sample a millisecond (the command line samples it at its ticks)."""
    with open(path, "w") as f:
        f.write("t,x,y,z,qw,qx,qy,qz,buttons\n")
        for i, (p, d) in enumerate(zip(poses, drill)):
            f.write(",".join(repr(float(v)) for v in (i * 1e-3, *p)) + f",{int(d)}\n")


def plunge(n):
    """A burr on a tilted shaft going into the block's top face and sideways, the drill
    off for the first tenth, the shaft turning about x: `n x 7` poses and drill flags."""
    s = np.linspace(0.0, 1.0, n)
    x = 0.25 * np.sin(2 * math.pi * s)
    y = 0.1 * s
    z = 0.62 - 0.3 * np.minimum(2 * s, 1.0)
    a = 0.4 * s  # rotation angle about x
    q = np.stack([np.cos(a / 2), np.sin(a / 2), 0 * a, 0 * a], axis=1)
    poses = np.concatenate([np.stack([x, y, z], axis=1), q], axis=1)
    drill = s > 0.1
    return poses, drill


def test_drilling_runs_poses_as_the_command_line_runs_a_trace(cli, tmp_path):
    poses, drill = plunge(2000)
    trace = tmp_path / "plunge.csv"
    write_trace(trace, poses, drill)
    mesh, tool = "builtin:block:4", "drill:0.1:0.5:0.03"
    want = cli(["--mesh", mesh, "--tool", tool, "--trace", str(trace)], tmp_path)
    n = want["ticks"]
    assert n >= len(poses) - 1

    d = td.Drilling(mesh, tool)
    forces = d.run(poses[:n], drill[:n])
    assert forces.shape == (n, 3)
    assert d.force_digest == want["force_digest"]
    d.erase_debris()
    same_regions(d.removed_by_region, want["removed_by_region"])
    assert close(d.removed_volume, want["removed_volume"])
    assert np.abs(forces).max() > 0
    d.validate()


def test_tick_by_tick_equals_a_batch_and_reset_starts_over():
    poses, drill = plunge(600)
    d = td.Drilling("builtin:block:4", "sphere:0.1")
    batch = d.run(poses, drill)
    digest, removed = d.force_digest, d.removed_volume
    assert d.ticks == 600 and d.time == pytest.approx(0.6)
    d.reset()
    assert d.ticks == 0 and d.removed_volume == 0.0
    one = np.array([d.tick(p, bool(f)) for p, f in zip(poses, drill)])
    assert np.array_equal(one, batch)
    assert d.force_digest == digest and d.removed_volume == removed


def test_a_burr_pressed_in_is_pushed_out_and_removes_material():
    d = td.Drilling("builtin:block:4", "sphere:0.1", max_force=100.0)
    # Drill off: the burr 0.05 into the top face (z = 0.5) is pushed straight up.
    f = d.tick([0.01, 0.02, 0.55], drill=False)
    for _ in range(50):
        f = d.tick([0.01, 0.02, 0.55], drill=False)
    assert f[2] > 0 and abs(f[0]) < 1e-3 * f[2] and abs(f[1]) < 1e-3 * f[2]
    assert d.removed_volume == 0.0
    # Drill on: material goes; each region's share adds up to the whole.
    d.run(np.tile([0.01, 0.02, 0.55], (300, 1)))
    assert d.removed_volume > 0
    assert sum(d.removed_by_region.values()) == pytest.approx(d.removed_volume, rel=1e-9)


def test_a_regions_feel_through_python_gives_the_command_lines_cutting_figures(cli, tmp_path):
    # The paper's cube cut by the feed, with a friction and a vibration, spinning
    # counter-clockwise: the burr plunges 0.4 into the top face tilted 30 degrees about +y.
    trace = tmp_path / "plunge.csv"
    q = "0.96592583,0,0.25881905,0"
    rows = [(0.0, 0.85), (0.5, 0.8), (4.5, 0.4), (5.0, 0.4)]
    trace.write_text(
        "t,x,y,z,qw,qx,qy,qz,buttons\n" + "".join(f"{t},0,0,{z},{q},1\n" for t, z in rows)
    )
    region = {"cutting_energy": 40.0, "friction": 0.2, "vibration": 0.5}
    toml = tmp_path / "feel.toml"
    toml.write_text(
        f'mesh = "builtin:cube12"\ntool = "sphere:0.15"\ntrace = "{trace}"\n'
        'vibration_hz = 250.0\nspin = "ccw"\n[regions.0]\n'
        + "".join(f"{k} = {v}\n" for k, v in region.items())
    )
    want = cli(["--scenario", str(toml)], tmp_path)
    figures = want["drill"]
    assert figures["cutting_work_j"] > 0 and figures["cutting_energy_j"] > 0

    # The scenario file, and the same settings as keywords.
    from_file = td.replay(toml)
    from_keys = td.replay(
        mesh="builtin:cube12",
        tool="sphere:0.15",
        trace=str(trace),
        vibration_hz=250.0,
        spin="ccw",
        regions={0: region},
    )
    for got in (from_file, from_keys):
        assert got["force_digest"] == want["force_digest"]
        assert got["cutting"] == figures
    # Tick by tick, then the final sweep: the same figures.
    d = td.Drilling(scenario=toml)
    poses, drill = d.trace_poses()
    d.run(poses, drill)
    d.erase_debris()
    assert d.cutting == figures
    c = d.cutting
    left = c["cutting_energy_j"] + c["feed_pool_j"] + c["feed_dropped_j"]
    assert close(c["cutting_work_j"], left, rel=1e-9)
    # Without the feel the forces differ and the feed does no work.
    plain = td.replay(toml, regions={0: {"threshold": 0.0}}, vibration_hz=0.0)
    assert plain["force_digest"] != want["force_digest"]
    assert plain["cutting"]["cutting_work_j"] == 0.0
