"""The paper's sweep (§VI): crosses the singular configuration on every pass, smoothly."""
import math
import warnings

import numpy as np
import pytest
from gpr_kinematics.core.config import MODELS
from gpr_kinematics.core.sweep import MAX_SAMPLES, paper_sweep, sweep_grid
from gpr_kinematics.errors import InputError, LimitError


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
    assert summary.samples == 756 and summary.max_fk_iterations <= 4 and summary.within_budget
    if model in ('radial', 'offset'):  # polar: docs/core.md; compliant: test_core_compliance
        assert summary.max_centre_shift == pytest.approx(28.41e-6, abs=0.01e-6)


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
    ({'height': float('nan')}, InputError, 'height = nan must be a finite number of metres'),
    ({'height': '0.5'}, InputError, "height = '0.5' must be a finite number of metres"),   # numpy would read it
    ({'passes': 0}, InputError, 'passes'),
    # --azimuth-step 400 --deg echoed 6.98 rad only
    ({'azimuth_step': math.radians(400.0)}, InputError,
     r'azimuth_step = 6\.98131\d* rad \(400 deg\) is more than a turn; allowed: at most 2 pi rad \(360 deg\)'),
    # a step beyond max_tilt was 'max_tilt ... must be a whole number (>= 1) of tilt steps': the default blamed
    ({'tilt_step': 0.2}, InputError,
     r'^tilt_step = 0\.2 rad is more than max_tilt = 0\.0349065\d* rad; allowed: a step that divides max_tilt a whole '
     r'number \(>= 1\) of times$'),
])
def test_sweep_rejects_bad_parameters(kwargs, exc, pattern):
    with pytest.raises(exc, match=pattern):
        paper_sweep(**kwargs)


@pytest.mark.parametrize('kwargs, message', [
    ({'height': True}, 'height = True must be a finite number of metres'),   # 1 m
    ({'azimuth_step': True}, 'azimuth_step = True must be a positive finite angle in radians'),   # 1 rad
    ({'tilt_step': True}, 'tilt_step = True must be a positive finite angle in radians'),
    ({'max_tilt': True}, 'max_tilt = True must be a positive finite angle in radians'),   # named beyond the limit
    ({'max_tilt': False}, 'max_tilt = False must be a positive finite angle in radians'),
    ({'passes': True}, 'passes = True must be an integer from 1 to 1000'),
    ({'serpentine': 'no'}, "serpentine = 'no'; allowed: True or False"),   # alternated the passes
    ({'serpentine': None}, 'serpentine = None; allowed: True or False'),   # the paper's order
])
def test_a_truth_value_for_a_number_or_anything_else_for_a_switch_is_refused(kwargs, message):
    with pytest.raises(InputError) as err:
        paper_sweep(**kwargs)
    assert str(err.value) == message


@pytest.mark.parametrize('kwargs, pattern', [
    ({'tilt_step': 1e-7}, r'the sweep would have 349066 tilt steps from level to its largest tilt; allowed: a '
                         r'sweep of at most 200000'),
    # below the least steps (trajectory_node's parameters' too): 1e-12 and 5e-324 were counted as samples
    ({'tilt_step': 5e-324}, r'tilt_step = 5e-324 rad; allowed: a step of at least 1e-07 rad'),
    ({'azimuth_step': 1e-9}, r'azimuth_step = 1e-09 rad; allowed: a step of at least 0.0001 rad'),
    ({'passes': 1000}, r'the sweep would have 756000 samples \(21 tilts x 36 azimuths x 1000 passes\); allowed: at '
                       r'most 200000'),
])
def test_sample_counts_are_refused_before_anything_is_allocated(kwargs, pattern):
    with pytest.raises(InputError, match=pattern):
        sweep_grid(**kwargs)
    g, _, _ = sweep_grid(max_tilt=math.radians(2), tilt_step=math.radians(2) / 99, azimuth_step=2 * math.pi / 1000)
    assert g.size == 199 * 1000 <= MAX_SAMPLES   # just below the limit: made


def test_hostile_heights_and_tilts_are_named_before_the_solve():
    with pytest.raises(LimitError, match=r'max_tilt = 1e\+300 rad .* is beyond the tilt limit; allowed: '
                                         r'max_tilt <= 0\.034906585 rad \(2 deg\)$'):
        paper_sweep(max_tilt=1e300)
    with warnings.catch_warnings():
        warnings.simplefilter('error')   # no overflow on the way to the message
        with pytest.raises(LimitError, match=r'height = -1e\+308 m puts a rod outside the stroke '
                                             r'\[0, 0\.508\] m at the tilt -0\.0349066 rad; allowed heights: '
                                             r'0\.00281913 \.\. 0\.50518 m'):
            paper_sweep(height=-1e308)
    # Those heights, independently: 2 deg about the x axis lifts rods 2 and 3 (at 120 and 240 deg) by
    # -+R sin(120 deg) sin(2 deg) against the platform origin, rod 1 (on the axis) not at all; the virtual joints
    # shift the rods by 1.7 um more (test_core_kinematics: either end named is solved).
    lift = 0.093218 * math.sin(math.radians(120)) * math.sin(math.radians(2.0))
    assert (round(lift, 8), round(0.508 - lift, 6)) == (0.00281741, 0.505183)


def test_summary_reports_the_largest_value_of_every_row_field():
    """The summary's maxima are those of the rows: the tilt reaches the paper's 2 deg, the centre shift peaks at
    a full tilt, and every other maximum is the largest of its row field (here computed from the rows, where the
    fields differ from row to row so that a smallest or a first value would not pass)."""
    s = paper_sweep(passes=2)
    fk, summary = s.forward, s.summary
    assert summary.passes == 2 and summary.samples == 2 * 756 and summary.singular_crossings == 72
    assert summary.max_tilt == pytest.approx(math.radians(2.0), rel=0, abs=1e-12)
    assert abs(summary.max_centre_shift_at.alpha) == pytest.approx(math.radians(2.0), rel=0, abs=1e-15)
    shift = np.hypot(fk.centre_shift[:, 0], fk.centre_shift[:, 1])
    expect = {'max_centre_shift': shift, 'max_joint_displacement': fk.joint_displacement,
              'max_residual': fk.residual, 'max_fit_residual': fk.fit_residual, 'max_fk_iterations': fk.iterations,
              'max_ik_iterations': s.inverse_iterations, 'max_height_error': np.abs(fk.position[:, 2] - 0.5)}
    for name, rows in expect.items():
        assert np.ptp(rows) > 0, name   # the rows differ
        assert getattr(summary, name) == np.max(rows), name
    i = int(np.argmax(shift))
    assert (summary.max_centre_shift_at.alpha, summary.max_centre_shift_at.gamma) == (s.alpha[i], s.gamma[i])


@pytest.mark.parametrize('argv, message', [
    (['--azimuth-step', '10'], '--azimuth-step = 10 rad is outside [-2pi, 2pi] rad; allowed: an angle in radians '
                               '(give --deg for degrees)'),
    (['--tilt-step', '0.2'], '--tilt-step = 0.2 rad is more than the tilt limit 0.0349066 rad (2 deg); allowed: a '
                             'step within it (give --deg for degrees)'),
    (['--azimuth-step', '400', '--deg'], '--azimuth-step = 400 deg is outside [-360, 360] deg; allowed: an angle of at '
                                         'most one turn'),
    # named as typed, not 'tilt_step = 0.0523598775598 rad is more than max_tilt = 0.0174532925199 rad'
    (['--tilt-step', '3', '--max-tilt', '1', '--deg'],
     '--tilt-step = 3 deg is more than --max-tilt = 1 deg; allowed: a step that divides --max-tilt a whole number '
     '(>= 1) of times'),
    (['--tilt-step', '0.03', '--max-tilt', '0.02'], '--tilt-step = 0.03 rad is more than --max-tilt = 0.02 rad; '
                                                     'allowed: a step that divides --max-tilt a whole number (>= 1) '
                                                     'of times'),
])
def test_gpr_sweep_names_a_typed_step_in_degrees_given_as_radians(capsys, argv, message):
    """``gpr sweep --azimuth-step 10`` and ``--tilt-step 0.2`` (degrees meant) named the radians without the --deg
    hint that ``gpr ik`` gives, the second blaming the default max_tilt."""
    from gpr_kinematics.cli.main import main

    assert main(['sweep', *argv]) == 2
    assert capsys.readouterr().err.strip().endswith(message)
    assert main(['sweep', '--tilt-step', '0.2', '--azimuth-step', '10', '--deg', '--json']) == 0


@pytest.mark.parametrize('argv, message', [
    # 'max_tilt = 0.008726646259971648 rad must be a whole number (>= 1) of tilt steps (0.003490658503988659 rad)'
    (['--max-tilt', '0.5', '--deg'], '--max-tilt = 0.5 deg is not a whole number (>= 1) of --tilt-step = 0.2 deg'),
    (['--max-tilt', '1', '--tilt-step', '0.3', '--deg'],
     '--max-tilt = 1 deg is not a whole number (>= 1) of --tilt-step = 0.3 deg'),
    (['--tilt-step', '0.3', '--deg'], '--max-tilt = 2 deg is not a whole number (>= 1) of --tilt-step = 0.3 deg'),
    (['--max-tilt', '0.03', '--tilt-step', '0.007'],
     '--max-tilt = 0.03 rad is not a whole number (>= 1) of --tilt-step = 0.007 rad'),
    (['--max-tilt', '0.03'], '--max-tilt = 0.03 rad is not a whole number (>= 1) of --tilt-step = 0.00349065850398866 '
                             'rad'),   # the default, 0.2 deg, in the unit of the others
])
def test_gpr_sweep_names_a_tilt_that_is_no_whole_number_of_steps_in_the_unit_typed(capsys, argv, message):
    """``gpr sweep --max-tilt 0.5 --deg`` was refused in the core's words, max_tilt and the step in radians: the
    options as typed, in the unit typed (degrees with --deg), one line, exit 2."""
    from gpr_kinematics.cli.main import main

    assert main(['sweep', *argv]) == 2
    out, err = capsys.readouterr()
    assert out == '' and err.count('\n') == 1 and 'Traceback' not in err
    assert err == (f'gpr sweep: error: {message}; allowed: a --tilt-step that divides --max-tilt a whole number of '
                   'times (every pass then crosses alpha = 0)\n'), err


@pytest.mark.parametrize('argv', [['--tilt-step', '0.03490658503988659'],
                                  ['--max-tilt', '1', '--tilt-step', '1', '--deg']])
def test_gpr_sweep_takes_a_tilt_step_equal_to_the_limit_or_to_max_tilt(capsys, argv):
    """A tilt step equal to the tilt limit (2 deg, in radians) is within it, one equal to --max-tilt is one step each
    way: 3 tilts (-max, 0, max) in each of the 36 azimuth rows."""
    import json

    from gpr_kinematics.cli.main import main

    assert main(['sweep', *argv, '--json']) == 0
    out = json.loads(capsys.readouterr().out)
    degrees = 1.0 if '--deg' in argv else 2.0
    assert out['samples'] == 3 * 36 and out['max_tilt'] == pytest.approx(math.radians(degrees), rel=1e-15)
    _, alpha, _ = sweep_grid(1.0, 1.0)
    assert sorted(set(alpha.tolist())) == [-1.0, 0.0, 1.0]
