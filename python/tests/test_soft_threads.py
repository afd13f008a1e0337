"""A soft body on one thread or two, and its arrays in the caller's order.

The body holds its nodes and tets in two parts of its own (docs/PYTHON.md, `SoftBody`); these
tests check what a caller sees of that: the same bits on two threads as on one, and every
array, node index and tet index in the order the caller gave.
"""

import numpy as np
import pytest

import tetradrill as td


def pressed(threads):
    b = td.SoftBody(
        "builtin:block:8", young=5000.0, substeps=4, gravity=[0, 0, -9.81], threads=threads
    )
    b.fix_below([0, 0, -0.49], [0, 0, 1])
    loads = np.zeros((b.node_count, 3))
    top = b.rest[:, 2] > 0.49
    loads[top] = [1.0, 0.0, -2.0]
    b.run(12, 0.004, loads)
    b.step(0.004)
    return b


def test_two_threads_give_the_bits_of_one():
    one, two = pressed(1), pressed(2)
    assert one.threads == 1 and two.threads == 2
    assert np.abs(one.displacements).max() > 1e-4, "the load moves the block"
    assert np.array_equal(one.displacements, two.displacements)
    assert np.array_equal(one.velocities, two.velocities)
    assert one.elastic_energy == two.elastic_energy


def test_threads_are_one_or_two():
    with pytest.raises(ValueError, match="threads must be 1 or 2, got 3"):
        td.SoftBody("builtin:block:2", threads=3)
    assert "threads=" in repr(td.SoftBody("builtin:block:2"))


def test_the_arrays_are_in_the_meshs_node_order():
    b = td.SoftBody("builtin:block:6", gravity=[0, 0, -9.81], threads=2)
    m = td.read_mesh("builtin:block:6")
    assert np.allclose(b.rest, m.nodes, atol=1e-6)
    assert (b.tets == m.tets).all()
    held = b.fix_below([0, 0, -0.49], [0, 0, 1])
    low = m.nodes[:, 2] < -0.49
    assert held == low.sum() and (b.fixed == low).all()
    b.run(20, 0.004)
    d = b.displacements
    assert (d[low] == 0).all(), "the held nodes, found by their rest positions, stay"
    # Under its own weight the block sags more the higher a node sits.
    z = m.nodes[:, 2]
    assert d[z > 0.49, 2].mean() < d[np.abs(z) < 0.01, 2].mean() < 0
    assert np.allclose(b.positions, b.rest + d, atol=1e-6)


def test_set_fixed_holds_the_callers_node(kuhn_strip):
    nodes, tets = kuhn_strip(8)
    b = td.SoftBody.from_arrays(nodes, tets, gravity=[0, 0, -9.81], threads=2)
    i = int(np.argmax(nodes[:, 0] + 0.1 * nodes[:, 1] + 0.01 * nodes[:, 2]))
    assert b.set_fixed(i, True) and not b.set_fixed(len(nodes), True)
    assert b.fixed.nonzero()[0].tolist() == [i]
    b.run(10, 0.004)
    d = b.displacements
    assert (d[i] == 0).all()
    assert (np.delete(d, i, axis=0)[:, 2] < 0).all(), "every other node falls"


def test_a_flat_tet_is_named_by_its_row(kuhn_strip):
    nodes, tets = kuhn_strip(6)
    order = np.random.default_rng(3).permutation(len(tets))
    given = tets[order].copy()
    k = 23
    given[k, [1, 2]] = given[k, [2, 1]]
    with pytest.raises(td.InputError, match=f"^soft body: tet {k} is inverted or flat at rest$"):
        td.SoftBody.from_arrays(nodes, given)
