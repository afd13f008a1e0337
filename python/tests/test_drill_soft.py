"""Drilling a soft body (`body="soft"`): the block gives way under the burr where a rigid one
does not, its nodes and surface show it, and `replay` gives the command line's forces and
volumes for the same scenario."""

import numpy as np

import tetradrill as td

from test_replay import write_trace


def press(n=600, depth=0.02):
    """The burr lowered `depth` into the block's top face (z = 0.5) over 200 ticks, then
    held: `n x 3` centres."""
    s = np.minimum(np.arange(n) / 200.0, 1.0)
    return np.stack([np.full(n, 0.06), np.full(n, -0.04), 0.6 - depth * s], axis=1)


def test_a_soft_block_gives_way_under_the_burr_where_a_rigid_one_does_not():
    poses = press()
    rigid = td.Drilling("builtin:block:4", "sphere:0.1")
    soft = td.Drilling("builtin:block:4", "sphere:0.1", body="soft", young=2000.0)
    fr = rigid.run(poses, drill=False)
    fs = soft.run(poses, drill=False)
    assert rigid.soft is None
    assert soft.soft["steps"] > 0 and soft.soft["fixed_nodes"] > 0
    # The rigid block's nodes stay; the soft one's top sinks under the burr, its base held.
    rest = rigid.positions
    assert np.array_equal(rest, td.Drilling("builtin:block:4", "sphere:0.1").positions)
    moved = soft.positions
    top, base = rest[:, 2] > 0.49, rest[:, 2] < -0.49
    assert moved[top, 2].min() < 0.5 - 1e-3
    assert np.array_equal(moved[base], rest[base])
    assert soft.soft["max_displacement"] >= 0.5 - moved[top, 2].min() - 1e-9
    # It pushes back less: the burr is less deep in a surface that moved away.
    assert 0 < fs[-1, 2] < fr[-1, 2]
    # The surface drawn is the moved one: its lowest corner on the top is the lowest top node.
    v = soft.surface().vertices
    assert abs(v[v[:, 2] > 0.4, 2].min() - moved[top, 2].min()) < 1e-7
    assert rigid.surface().vertices[:, 2].max() == 0.5
    # reset: the body at rest again, the same forces.
    soft.reset()
    assert np.array_equal(soft.positions, rest)
    assert np.array_equal(soft.run(poses, drill=False), fs)


def test_drilling_a_soft_body_is_the_command_lines(cli, tmp_path):
    centres = press(1200, 0.05)
    poses = np.concatenate([centres, np.tile([1.0, 0, 0, 0], (len(centres), 1))], axis=1)
    drill = np.arange(len(centres)) > 100
    trace = tmp_path / "press.csv"
    write_trace(trace, poses, drill)
    keys = ["--mesh", "builtin:block:4", "--tool", "sphere:0.1", "--trace", str(trace)]
    soft = ["--body", "soft", "--young", "3000", "--fix-below", "z:-0.49"]
    want = cli(keys + soft, tmp_path)
    got = td.replay(mesh="builtin:block:4", tool="sphere:0.1", trace=str(trace), body="soft",
                    young=3000.0, fix_below="z:-0.49")
    assert got["force_digest"] == want["force_digest"]
    assert got["removed_volume"] == want["removed_volume"] > 0
    assert got["deform"]["steps"] == want["deform"]["steps"] > 0
    assert got["deform"]["max_displacement"] == want["deform"]["max_displacement"] > 1e-3
