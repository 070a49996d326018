"""min_cost_assignment: scipy's assignment, without scipy.optimize for one row or column."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from conformorph.geometry.assignment import min_cost_assignment


def test_hand_worked() -> None:
    # 2x2: the diagonal costs 1 + 1, the other 3 + 4
    r, c = min_cost_assignment(np.array([[1.0, 3.0], [4.0, 1.0]]))
    assert r.tolist() == [0, 1] and c.tolist() == [0, 1]
    r, c = min_cost_assignment(np.array([[5.0, 2.0, 2.0, 7.0]]))  # first of equal minima
    assert r.tolist() == [0] and c.tolist() == [1]
    r, c = min_cost_assignment(np.array([[5.0], [-1.0], [3.0]]))
    assert r.tolist() == [1] and c.tolist() == [0]
    r, c = min_cost_assignment(np.zeros((0, 3)))
    assert r.size == 0 and c.size == 0 and r.dtype == np.int64


@pytest.mark.parametrize("shape", [(1, 1), (1, 6), (6, 1), (3, 3), (4, 7), (7, 4)])
def test_the_same_total_as_scipy(shape: tuple[int, int]) -> None:
    rng = np.random.default_rng(sum(shape))
    for _ in range(20):
        C = rng.normal(size=shape)
        r, c = min_cost_assignment(C)
        rs, cs = linear_sum_assignment(C)
        assert np.all(np.diff(r) > 0) and len(set(c.tolist())) == len(c)
        assert C[r, c].sum() == pytest.approx(C[rs, cs].sum(), abs=1e-12)


def test_a_single_row_needs_no_scipy_optimize() -> None:
    code = (
        "import sys, numpy as np\n"
        "from conformorph.geometry.assignment import min_cost_assignment\n"
        "min_cost_assignment(np.array([[2.0, 1.0]]))\n"
        "print('scipy.optimize' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_refuses_what_is_no_matrix() -> None:
    with pytest.raises(ValueError, match="2-d"):
        min_cost_assignment(np.zeros(3))
