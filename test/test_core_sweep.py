"""The paper's sweep (§VI): crosses the singular configuration on every pass, smoothly."""
import math
import warnings

import numpy as np
import pytest

from gpr_kinematics.config import MODELS
from gpr_kinematics.errors import InputError, LimitError
from gpr_kinematics.sweep import paper_sweep, sweep_grid


@pytest.mark.parametrize('model', MODELS)
def test_default_sweep_crosses_singularity_without_nan_jump_or_warning(model):
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        with np.errstate(all='raise'):
            s = paper_sweep(model=model)
    fk = s.forward
    assert len(s) == 36 * 21 and int(np.count_nonzero(s.singular)) == 36
    for name in ('virtual_joints', 'position', 'quaternion', 'side_lengths', 'tilt', 'centre_shift'):
        assert np.all(np.isfinite(getattr(fk, name))), name
    assert fk.iterations.max() <= 4
    assert np.max(np.abs(fk.position[:, 2] - 0.5)) < 1e-12
    assert np.max(np.abs(fk.tilt - np.abs(s.alpha))) < 1e-12
    at = np.flatnonzero(s.singular)
    np.testing.assert_allclose(s.q[at], 0.5, atol=1e-15)
    # Continuity: within a pass the change per sample is the same at the crossing as next to it.
    for name in ('virtual_joints', 'position', 'side_lengths'):
        v = getattr(fk, name)
        step = np.abs(np.diff(v, axis=0)).max(axis=-1) if v.ndim > 1 else np.abs(np.diff(v))
        same_pass = s.pass_index[1:] == s.pass_index[:-1]
        around = np.concatenate([at - 1, at])  # steps into and out of each crossing
        around = around[(around >= 0) & (around < step.size)]
        inner = step[same_pass & (np.abs(s.alpha[1:]) + np.abs(s.alpha[:-1]) > 0)]
        assert step[around].max() <= 1.5 * inner.max() + 1e-15, name
    summary = s.summary
    assert summary['samples'] == 756 and summary['max_fk_iterations'] <= 4 and summary['within_budget']
    if model in ('radial', 'offset'):  # polar: docs/core.md; compliant: test_core_compliance
        assert summary['max_centre_shift'] == pytest.approx(28.41e-6, abs=0.01e-6)


def test_serpentine_order_is_continuous_and_paper_order_is_not():
    g, a, p = sweep_grid(passes=2)
    assert np.max(np.abs(np.diff(a))) <= math.radians(0.2) + 1e-15  # direction alternates
    g2, a2, _ = sweep_grid(serpentine=False)
    assert np.max(np.abs(np.diff(a2))) == pytest.approx(math.radians(4.0))
    assert p.max() == 1 and g.size == 2 * 756 and g2.size == 756


@pytest.mark.parametrize('kwargs, exc, pattern', [
    ({'tilt_step': 0.0}, InputError, 'tilt_step = 0.0 must be a positive'),
    ({'max_tilt': math.radians(2.0), 'tilt_step': math.radians(0.3)}, InputError, 'whole number'),
    ({'max_tilt': math.radians(3.0)}, LimitError, 'beyond the tilt limit'),
    ({'height': 0.507}, LimitError, 'outside the stroke'),
    ({'height': float('nan')}, InputError, 'height'),
    ({'passes': 0}, InputError, 'passes'),
])
def test_sweep_rejects_bad_parameters(kwargs, exc, pattern):
    with pytest.raises(exc, match=pattern):
        paper_sweep(**kwargs)
