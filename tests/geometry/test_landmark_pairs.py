import numpy as np
import pytest

from conformorph.geometry.landmark_pairs import landmark_rms, validate_landmark_pairs
from conformorph.geometry.mobius_registration import mobius_registration
from conformorph.geometry.registration_error import disk_registration_error
from conformorph.geometry.thin_plate_registration import thin_plate_registration


def test_landmark_rms_hand_worked_and_relation_to_eq2():
    a = np.array([[0.0, 0.0], [0.3, 0.0]])
    b = np.array([[0.0, 0.4], [0.0, 0.0]])
    # distances 0.4 and 0.3: rms = sqrt((0.16 + 0.09) / 2), E_D = 0.5
    assert landmark_rms(a, b) == pytest.approx(np.sqrt(0.125))
    assert landmark_rms(a, b) * np.sqrt(2) == pytest.approx(disk_registration_error(a, b))
    assert landmark_rms(a, a) == 0.0
    with pytest.raises(ValueError):
        landmark_rms(a, b[:1])


def test_validate_landmark_pairs_errors():
    P = np.array([[0.0, 0.0], [0.5, 0.1], [-0.2, 0.3]])
    P2, Q2 = validate_landmark_pairs(P.tolist(), P, min_count=3, fit="f")
    assert P2.dtype == np.float64 and np.array_equal(P2, Q2)
    with pytest.raises(ValueError, match="both be"):
        validate_landmark_pairs(P, P[:2], min_count=2, fit="f")
    with pytest.raises(ValueError, match="at least 4 landmarks to fit f"):
        validate_landmark_pairs(P, P, min_count=4, fit="f")
    bad = P.copy()
    bad[0, 0] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        validate_landmark_pairs(bad, P, min_count=3, fit="f")
    out = P.copy()
    out[1] = [1.2, 0.0]
    validate_landmark_pairs(out, P, min_count=3, fit="f")  # no disk test by default
    with pytest.raises(ValueError, match="closed unit disk"):
        validate_landmark_pairs(P, out, min_count=3, fit="f", disk="closed")
    on_circle = P.copy()
    on_circle[1] = [1.0, 0.0]
    validate_landmark_pairs(on_circle, P, min_count=3, fit="f", disk="closed")


def test_both_fits_share_the_checks():
    P = np.array([[0.0, 0.0], [0.5, 0.1]])
    with pytest.raises(ValueError, match="at least 3 landmarks"):
        thin_plate_registration(P, P)
    with pytest.raises(ValueError, match="at least 2 landmarks"):
        mobius_registration(P[:1], P[:1])
    with pytest.raises(ValueError, match="non-finite"):
        thin_plate_registration(np.r_[P, [[np.inf, 0]]], np.r_[P, [[0, 0]]])
