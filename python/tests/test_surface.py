"""The drilled surface against analytic values: the undrilled unit cube's six faces."""

import numpy as np

import tetradrill as td


def areas(s):
    v, t = s.vertices, s.triangles
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def test_the_undrilled_cube_is_six_unit_faces():
    d = td.Drilling("builtin:block:3", "sphere:0.1")
    s = d.surface()
    n = len(s)
    assert s.vertices.shape == (3 * n, 3) and s.normals.shape == (3 * n, 3)
    assert s.triangles.shape == (n, 3) and s.labels.shape == (n,)
    # 3 x 3 squares a face, 2 triangles a square, 6 faces.
    assert n == 6 * 9 * 2
    assert abs(areas(s).sum() - 6.0) < 1e-5
    assert abs(s.area - 6.0) < 1e-5
    # Every corner on the cube's boundary.
    assert np.allclose(np.abs(s.vertices).max(axis=1), 0.5, atol=1e-6)
    # Normals: unit, one of the six axes, outward, consistent with the winding.
    face_n = s.normals[0::3]
    assert np.allclose(np.linalg.norm(face_n, axis=1), 1.0, atol=1e-6)
    centroids = s.vertices.reshape(n, 3, 3).mean(axis=1)
    assert (np.einsum("ij,ij->i", face_n, centroids) > 0.49).all()
    v = s.vertices.reshape(n, 3, 3)
    wind = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    assert (np.einsum("ij,ij->i", wind, face_n) > 0).all()
    # One unit of area on each face of the cube.
    for axis in range(3):
        for sign in (-1, 1):
            on = np.isclose(face_n[:, axis], sign, atol=1e-6)
            assert abs(areas(s)[on].sum() - 1.0) < 1e-6
    # The block's shell and core (labels 1 and 2): its surface is all shell.
    assert set(np.unique(s.labels)) == {1}
    assert s.to_obj().count("\nf ") == n


def test_drilling_opens_the_surface():
    d = td.Drilling("builtin:block:4", "sphere:0.15")
    d.run(np.tile([0.0, 0.0, 0.5], (500, 1)))
    s = d.surface()
    assert d.removed_volume > 0
    # A dimple's walls: more area than the flat face they replaced.
    assert s.area > 6.0
    assert abs(areas(s).sum() - s.area) < 1e-9 * s.area


def test_smooth_normals_are_unit_per_corner_and_agree_at_shared_corners():
    d = td.Drilling("builtin:block:4", "sphere:0.15")
    d.run(np.tile([0.0, 0.0, 0.5], (500, 1)))
    s = d.surface()
    n = len(s)
    sn = s.smooth_normals
    assert sn.shape == (3 * n, 3)
    assert np.allclose(np.linalg.norm(sn, axis=1), 1.0, atol=1e-5)
    # On the drilled dimple the corners of one face differ (a curved surface).
    per_face = sn.reshape(n, 3, 3)
    bent = ~np.isclose(per_face, per_face[:, :1], atol=1e-6).all(axis=(1, 2))
    assert bent.sum() > n // 10
    # Drilled corners at one position have one normal (shared vertices): group the corners
    # that lie inside the block (off its faces) by position.
    inside = (np.abs(s.vertices).max(axis=1) < 0.5 - 1e-6)
    keys = {}
    for p, nn in zip(map(tuple, s.vertices[inside]), sn[inside]):
        keys.setdefault(p, []).append(nn)
    shared = [np.ptp(np.array(v), axis=0).max() for v in keys.values() if len(v) > 1]
    assert len(shared) > 10 and max(shared) < 1e-6
