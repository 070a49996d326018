import numpy as np
import pytest

from conformorph import geometry as g
from tests.meshes import bumpy_disk, disk_grid


def ok_mesh():
    return bumpy_disk(4)


def test_valid_disk_passes():
    V, F = ok_mesh()
    r = g.validate_mesh(V, F)
    assert (r.boundary_loops, r.euler_characteristic, r.components) == (1, 1, 1)
    assert r.n_vertices == len(V) and r.boundary.size == r.boundary_loop_sizes[0]


def test_not_triangles():
    V, F = ok_mesh()
    with pytest.raises(g.NotTrianglesError, match="triangles"):
        g.validate_mesh(V, np.column_stack([F, F[:, :1]]))
    with pytest.raises(g.NotTrianglesError, match=r"\(n, 3\)"):
        g.validate_mesh(V[:, :2], F)


def test_nan_coordinates_named():
    V, F = ok_mesh()
    V[7, 1] = np.nan
    with pytest.raises(g.NonFiniteCoordinatesError, match=r"\[7\]"):
        g.validate_mesh(V, F)


def test_index_out_of_range_and_repeated():
    V, F = ok_mesh()
    F2 = F.copy()
    F2[3, 1] = len(V)
    with pytest.raises(g.FaceIndexOutOfRangeError, match="face 3"):
        g.validate_mesh(V, F2)
    F2[3, 1] = -1
    with pytest.raises(g.FaceIndexOutOfRangeError, match=r"face 3 is \[\d+, -1"):
        g.validate_mesh(V, F2)
    F2 = F.copy()
    F2[5, 2] = F2[5, 0]
    with pytest.raises(g.RepeatedFaceIndexError, match="repeat a vertex: face 5"):
        g.validate_mesh(V, F2)


@pytest.mark.parametrize(
    ("cls", "code"),
    [
        (g.FaceIndexOutOfRangeError, "face_index_out_of_range"),
        (g.RepeatedFaceIndexError, "repeated_face_index"),
    ],
)
def test_face_index_errors_are_distinct_subclasses(cls, code):
    # distinct types (and API codes) per failure; FaceIndexError still catches both
    assert issubclass(cls, g.FaceIndexError) and issubclass(cls, g.MeshError)
    assert cls.code == code != g.FaceIndexError.code
    assert not issubclass(g.FaceIndexOutOfRangeError, g.RepeatedFaceIndexError)
    assert not issubclass(g.RepeatedFaceIndexError, g.FaceIndexOutOfRangeError)


def test_element_checks_alone_pass_a_non_disk_and_fail_like_validate_mesh():
    V, F = ok_mesh()
    # two components and ears are not element problems
    V2, F2 = g.validate_mesh_elements(np.vstack([V, V + 5]), np.vstack([F, F + len(V)]))
    assert V2.shape == (2 * len(V), 3) and F2.dtype == np.int64
    F3 = F.copy()
    F3[0, 0] = len(V) + 3
    with pytest.raises(g.FaceIndexOutOfRangeError, match="face 0"):
        g.validate_mesh_elements(V, F3)
    with pytest.raises(g.UnreferencedVertexError):
        g.validate_mesh_elements(np.vstack([V, [[9.0, 9, 9]]]), F)
    with pytest.raises(g.NotTrianglesError):
        g.validate_mesh_elements(V, F[:, :2])


def test_zero_area():
    V, F = ok_mesh()
    a, b, c = F[4]
    V[c] = 0.5 * (V[a] + V[b])
    with pytest.raises(g.ZeroAreaFaceError):
        g.validate_mesh(V, F)


def test_unreferenced_vertex():
    V, F = ok_mesh()
    with pytest.raises(g.UnreferencedVertexError, match=str(len(V))):
        g.validate_mesh(np.vstack([V, [[9.0, 9, 9]]]), F)


def test_nonmanifold_edge():
    V, F = ok_mesh()
    i, j, _ = F[0]
    V2 = np.vstack([V, [[0.3, 0.3, 2.0]]])
    with pytest.raises(g.NonManifoldError, match="edges"):
        g.validate_mesh(V2, np.vstack([F, [[i, j, len(V)]], [[j, i, len(V)]]]))


def test_nonmanifold_vertex_bowtie():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0.1]])
    F = np.array([[0, 1, 2], [0, 3, 4]])
    with pytest.raises(g.NonManifoldError):
        g.validate_mesh(V, F)


def test_two_components():
    V, F = ok_mesh()
    V2 = np.vstack([V, V + [5, 0, 0]])
    with pytest.raises(g.MultipleComponentsError, match="2 connected components"):
        g.validate_mesh(V2, np.vstack([F, F + len(V)]))


def test_hole_reported_and_fillable():
    V, F = disk_grid(5)
    centre = np.argmin(np.hypot(V[:, 0], V[:, 1]))
    F_hole = F[~np.any(F == centre, axis=1)]
    keep = np.unique(F_hole)
    remap = np.full(len(V), -1)
    remap[keep] = np.arange(len(keep))
    V2, F2 = V[keep], remap[F_hole]
    with pytest.raises(
        g.NotDiskError, match="2 boundary loops and Euler characteristic 0.*holes: loop 1"
    ):
        g.validate_mesh(V2, F2)
    V3, F3 = g.fill_holes(V2, F2)
    np.testing.assert_array_equal(V3[: len(V2)], V2)
    assert g.validate_mesh(V3, F3).boundary_loops == 1


def test_closed_surface_is_not_disk():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    F = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    with pytest.raises(g.NotDiskError, match="0 boundary loops"):
        g.validate_mesh(V, F)


def test_ears_reported_and_removable():
    V, F = ok_mesh()
    b = g.boundary_loop(F)
    i, j = b[0], b[1]
    p = 0.5 * (V[i] + V[j]) * 1.3
    V2 = np.vstack([V, p])
    F2 = np.vstack([F, [[j, i, len(V)]]])
    with pytest.raises(g.BoundaryEarError, match=str(len(V))):
        g.validate_mesh(V2, F2)
    V3, F3, kept = g.remove_boundary_ears(V2, F2)
    assert len(V) - 5 <= len(V3) <= len(V)
    g.validate_mesh(V3, F3)
    np.testing.assert_array_equal(V3, V2[kept])
