"""Identifiability analysis (gpr_kinematics.calibration.identifiability) on Jacobians whose deficiencies are known
by construction."""
from __future__ import annotations

import numpy as np
import pytest
from gpr_kinematics.calibration.identifiability import analyse, triangular_factor


def test_full_rank_identifies_everything():
    rng = np.random.default_rng(0)
    J = rng.normal(size=(60, 4)) * 10
    a = analyse(J, ['a', 'b', 'c', 'd'])
    assert a.identified == ('a', 'b', 'c', 'd') and a.held == () and a.combinations == ()
    np.testing.assert_allclose(a.singular_values, np.linalg.svd(J, compute_uv=False), rtol=1e-12)
    assert a.condition_number == pytest.approx(a.singular_values[0] / a.singular_values[-1])
    np.testing.assert_allclose(np.abs(triangular_factor(J)), np.abs(np.linalg.qr(J)[1]), rtol=1e-12)


def test_exact_combination_is_named_and_the_last_of_a_tie_held():
    rng = np.random.default_rng(1)
    base = rng.normal(size=(50, 3)) * 10
    # column 4 = -(col0 + col1 + col2): a change +1 of all four is invisible (like base_z and the three offsets)
    J = np.column_stack([base, -base.sum(axis=1)])
    a = analyse(J, ['offset1', 'offset2', 'offset3', 'base_z'])
    assert a.held == ('base_z',) and a.identified == ('offset1', 'offset2', 'offset3')
    (c,) = a.combinations
    assert c.singular_value < 1e-9 and c.held == 'base_z'
    assert set(c.coefficients) == {'offset1', 'offset2', 'offset3', 'base_z'}
    np.testing.assert_allclose(list(c.coefficients.values()), [1.0] * 4, rtol=1e-9)
    text = c.describe()
    assert 'are not separable: the poses cannot see a change of +1 ' in text
    assert all(f'+1 {n}' in text for n in ('offset1', 'offset2', 'offset3', 'base_z'))
    assert c.describe().endswith('base_z held at nominal')


def test_a_parameter_below_the_prior_is_held_alone():
    rng = np.random.default_rng(2)
    J = rng.normal(size=(40, 3)) * 20
    J[:, 1] *= 1e-3              # the measurements see b 50x less well than its prior uncertainty
    a = analyse(J, ['a', 'b', 'c'])
    assert a.held == ('b',) and list(a.combinations[0].coefficients) == ['b']
    assert 'b is not identifiable from these poses' in a.combinations[0].describe()
    # A lower bound accepts it; the numerical bound still applies.
    assert analyse(J, ['a', 'b', 'c'], threshold=0.01).held == ()
    J[:, 1] = 0.0
    assert analyse(J, ['a', 'b', 'c'], threshold=1e-30).held == ('b',)



@pytest.mark.parametrize('threshold', [float('nan'), 0.0, -1.0, float('inf'), 'a', None, 10 ** 400])
def test_a_threshold_that_is_not_a_positive_number_is_refused(threshold):
    """NaN fitted no parameter, with NaN standard errors, and raised nothing; strings were bare errors."""
    from gpr_kinematics.errors import InputError

    J = np.random.default_rng(2).normal(size=(40, 3))
    with pytest.raises(InputError, match=r'threshold = .*; allowed: a finite number > 0'):
        analyse(J, ['a', 'b', 'c'], threshold=threshold)

def test_two_deficiencies_hold_two_parameters():
    rng = np.random.default_rng(3)
    base = rng.normal(size=(30, 3)) * 10
    J = np.column_stack([base, base[:, 0] - base[:, 1], 2 * base[:, 2]])
    a = analyse(J, ['p', 'q', 'r', 's', 't'])
    assert len(a.held) == 2 and len(a.identified) == 3
    sub = np.linalg.svd(J[:, [a.names.index(n) for n in a.identified]], compute_uv=False)
    assert sub[-1] > 1.0
    np.testing.assert_allclose(a.fitted_singular_values, sub, rtol=1e-12)
