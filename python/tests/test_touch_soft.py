"""Touching with a tet-mesh tool and a soft body, against what the physics says."""

from pathlib import Path

import numpy as np
import pytest

import tetradrill as td

PEN = Path(__file__).resolve().parents[2] / "tests/data/meshes/models/pen_tool_gmsh.mesh"


def test_the_pen_feels_the_block_only_inside_and_more_deeper():
    t = td.Touching("builtin:block:6", PEN, max_force=1.0e6)
    assert t.tool_nodes > 0 and t.object_nodes == 7**3
    z = 0.55 - 0.005 * np.arange(27)
    poses = np.stack([np.full(27, 0.01), np.full(27, 0.02), z], axis=1)
    f = t.run(poses)
    assert f.shape == (27, 3)
    # Above the top face (z = 0.5): nothing.
    assert (f[z > 0.5 + 1e-4] == 0).all()
    inside = f[z < 0.49]
    assert (inside[:, 2] > 0).all(), "the block pushes the pen back up"
    assert (np.diff(inside[:, 2]) >= 0).all(), "more force deeper"
    full = t.run(poses, full=True)
    assert np.array_equal(full["force"], f)
    assert (full["penetrations"][z < 0.49].sum(axis=1) > 0).all()
    assert (full["penetrations"][z > 0.5 + 1e-4] == 0).all()


def sweep(n):
    """The pen pressed into block:6's top and dragged sideways, tilting: `n x 7` poses."""
    s = np.linspace(0.0, 1.0, n)
    a = 0.5 * s
    return np.stack(
        [0.2 * s - 0.1, np.full(n, 0.02), 0.52 - 0.06 * np.minimum(3 * s, 1.0),
         np.cos(a / 2), np.sin(a / 2), 0 * s, 0 * s],
        axis=1,
    )


def test_touching_goes_on_from_call_to_call_and_reset_starts_over():
    # The scene and the pen's state (damping, lists, crossings) are kept between calls: a run
    # in two calls is the run in one, bit for bit, and reset() is a new object.
    poses = sweep(120)
    one = td.Touching("builtin:block:6", PEN, max_force=1.0e6, damping=0.5)
    whole = one.run(poses, full=True)
    assert one.ticks == 120
    assert (whole["penetrations"].sum(axis=1) > 0).sum() > 60, "the pen is in the block"
    two = td.Touching("builtin:block:6", PEN, max_force=1.0e6, damping=0.5)
    first = two.run(poses[:50], full=True)
    second = two.run(poses[50:], full=True)
    for key in ("force", "raw", "display_offset", "penetrations"):
        assert np.array_equal(np.concatenate([first[key], second[key]]), whole[key]), key
    # The damping remembers the last call: the second call's first force is not the one a
    # pen starting from rest there feels.
    cold = td.Touching("builtin:block:6", PEN, max_force=1.0e6, damping=0.5).run(poses[50:51])
    assert not np.array_equal(cold[0], whole["force"][50])
    two.reset()
    assert two.ticks == 0
    assert np.array_equal(two.run(poses), whole["force"])


def test_a_free_soft_body_falls_as_a_stone():
    # No support, no damping: every node moves by g t^2 / 2 and nothing deforms.
    g = np.array([0.0, 0.0, -9.81])
    b = td.SoftBody("builtin:block:2", gravity=g, substeps=10)
    b.run(100, 0.01)
    t = b.time
    assert t == pytest.approx(1.0)
    want = 0.5 * g * t * t
    assert np.allclose(b.displacements, want, rtol=0.02, atol=1e-6)
    assert np.allclose(b.positions, b.rest + b.displacements, atol=1e-6)
    assert b.elastic_energy < 1e-9


def sag(load):
    b = td.SoftBody("builtin:block:4", young=5000.0, poisson=0.3, damping=20.0, substeps=20)
    held = b.fix_below([0, 0, -0.49], [0, 0, 1])
    assert held == 25 and b.fixed.sum() == 25
    top = b.rest[:, 2] > 0.49
    loads = np.zeros((b.node_count, 3))
    loads[top, 2] = -load / top.sum()
    b.run(250, 0.004, loads)
    d = b.displacements
    return -d[top, 2].mean(), np.abs(d[b.fixed]).max()


def test_twice_the_load_twice_the_dent_and_the_held_nodes_stay():
    one, held1 = sag(50.0)
    two, held2 = sag(100.0)
    assert one > 0 and 1.9 < two / one < 2.1
    assert held1 == 0 and held2 == 0


def test_a_body_from_arrays_and_an_inverted_tet():
    nodes = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    b = td.SoftBody.from_arrays(nodes, [[0, 1, 2, 3]])
    assert b.node_count == 4 and b.tet_count == 1
    b.step(0.01)
    assert (b.displacements == 0).all(), "no load, no motion"
    with pytest.raises(td.InputError, match="soft body"):
        td.SoftBody.from_arrays(nodes, [[0, 2, 1, 3]])
    with pytest.raises(ValueError, match="node index 7"):
        td.SoftBody.from_arrays(nodes, [[0, 1, 2, 7]])


def test_a_body_hands_back_its_tets_in_the_order_given(kuhn_strip):
    # A strip of cubes, six tets each, given in a scrambled order: the body groups them for its
    # lanes inside, and hands them back in the order given.
    nodes, tets = kuhn_strip(6)
    order = np.random.default_rng(7).permutation(len(tets))
    given = tets[order]
    b = td.SoftBody.from_arrays(nodes, given, young=5000.0, substeps=4, gravity=[0, 0, -9.81])
    assert (b.tets == given).all()
    b.fix_below([0, 0, 0], [0, 0, 1])
    b.run(20, 0.004)
    assert np.isfinite(b.displacements).all() and b.displacements[:, 2].min() < 0
