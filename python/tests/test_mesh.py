"""Mesh files: what `read_mesh` gives against tiny files written here and parsed here, and
bad files named with their line."""

import numpy as np
import pytest

import tetradrill as td

MEDIT = """MeshVersionFormatted 1
Dimension 3
# five vertices, two tets sharing a face
Vertices
5
0 0 0 1
1 0 0 1
0 1 0 1
0 0 1 1
1 1 1 1
Tetrahedra
2
1 2 3 4 7
2 3 4 5 9
End
"""


def parse_medit(text):
    """An independent reading: tokens after each section keyword."""
    lines = [l.split("#")[0] for l in text.splitlines()]
    tokens = " ".join(lines).split()
    i = tokens.index("Vertices")
    nv = int(tokens[i + 1])
    vals = tokens[i + 2 : i + 2 + 4 * nv]
    nodes = [[float(v) for v in vals[4 * k : 4 * k + 3]] for k in range(nv)]
    j = tokens.index("Tetrahedra")
    nt = int(tokens[j + 1])
    vals = tokens[j + 2 : j + 2 + 5 * nt]
    tets = [[int(v) - 1 for v in vals[5 * k : 5 * k + 4]] for k in range(nt)]
    labels = [int(vals[5 * k + 4]) for k in range(nt)]
    return np.array(nodes), np.array(tets), np.array(labels)


def test_a_medit_file_as_it_lists_its_nodes_tets_and_labels(tmp_path):
    p = tmp_path / "two.mesh"
    p.write_text(MEDIT)
    m = td.read_mesh(p)
    nodes, tets, labels = parse_medit(MEDIT)
    assert m.nodes.shape == (5, 3) and m.tets.shape == (2, 4) and m.labels.shape == (2,)
    assert np.array_equal(m.nodes, nodes)
    assert np.array_equal(m.tets, tets)
    assert np.array_equal(m.labels, labels)
    assert m.nodes.dtype == np.float64 and m.tets.dtype == np.int64 and m.labels.dtype == np.int32
    assert m.format == "medit"
    assert repr(m) == 'Mesh(format="medit", nodes=5, tets=2)'
    # Each tet's line in the file.
    lines = MEDIT.splitlines()
    assert [lines[l - 1].split()[:4] for l in m.tet_lines] == [
        [str(v + 1) for v in t] for t in tets
    ]


def test_a_tetgen_pair_with_region_attributes(tmp_path):
    node = tmp_path / "pair.node"
    node.write_text("5 3 0 0\n1 0 0 0\n2 2 0 0\n3 0 2 0\n4 0 0 2\n5 2 2 2\n")
    (tmp_path / "pair.ele").write_text("2 4 1\n1 1 2 3 4 -3\n2 2 3 4 5 12\n")
    m = td.read_mesh(node)
    assert np.array_equal(m.nodes, [[0, 0, 0], [2, 0, 0], [0, 2, 0], [0, 0, 2], [2, 2, 2]])
    assert np.array_equal(m.tets, [[0, 1, 2, 3], [1, 2, 3, 4]])
    assert np.array_equal(m.labels, [-3, 12])


def test_a_built_in_block_has_its_six_n_cubed_tets_and_two_regions():
    m = td.read_mesh("builtin:block:3")
    assert m.tets.shape == (6 * 27, 4)
    assert m.nodes.shape == (64, 3)
    assert set(np.unique(m.labels)) == {1, 2}


def test_a_bad_number_names_the_file_and_line(tmp_path):
    bad = MEDIT.replace("0 1 0 1", "0 one 0 1")
    line = bad.splitlines().index("0 one 0 1") + 1
    p = tmp_path / "bad.mesh"
    p.write_text(bad)
    with pytest.raises(td.InputError, match=f"{p}:{line}:"):
        td.read_mesh(p)
    # The same line when a drilling reads it.
    with pytest.raises(td.InputError, match=f"{p}:{line}:"):
        td.Drilling(p, "sphere:0.1")


def test_a_missing_file_is_named(tmp_path):
    p = tmp_path / "absent.mesh"
    with pytest.raises(td.InputError, match=str(p)):
        td.read_mesh(p)
