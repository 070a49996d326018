import numpy as np
import pytest

from conformorph.geometry.vertex_pull import MutualNearestVertices

UP = np.array([0.0, 0.0, 1.0])


def test_mutual_nearest_pairs_by_hand():
    """Source 0 and target 0 are each other's nearest; source 1's nearest target (1) is
    nearer to source 2, so 1 is unpaired and 2 is paired with it; source 3 is too far
    from its nearest target; source 4's normal is turned away."""
    T = np.array([[0.0, 0, 0], [1.0, 0, 0], [5.0, 0, 0], [9.0, 0, 0]])
    S = np.array([[0.1, 0, 0], [1.4, 0, 0], [1.1, 0, 0], [5.0, 3.0, 0], [9.0, 0.1, 0]])
    nt = np.tile(UP, (4, 1))
    ns = np.tile(UP, (5, 1))
    ns[4] = [1.0, 0.0, 0.0]
    vp = MutualNearestVertices(T, nt).pairs(S, ns, max_distance=1.0, min_normal_cosine=0.5)
    np.testing.assert_array_equal(vp.target, [0, 1, 1, 2, 3])
    np.testing.assert_array_equal(vp.paired, [True, False, True, False, False])
    # within a larger distance source 3 pairs with target 2 (each is the other's nearest)
    vp = MutualNearestVertices(T, nt).pairs(S, ns, max_distance=4.0, min_normal_cosine=0.5)
    np.testing.assert_array_equal(vp.paired, [True, False, True, True, False])


def test_validation():
    with pytest.raises(ValueError, match="target_V"):
        MutualNearestVertices(np.zeros((3, 2)), np.zeros((3, 2)))
    m = MutualNearestVertices(np.zeros((1, 3)), np.tile(UP, (1, 1)))
    with pytest.raises(ValueError, match="source_V"):
        m.pairs(np.zeros((2, 3)), np.zeros((3, 3)), 1.0, 0.0)
