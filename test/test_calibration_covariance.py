"""The calibrated geometry file's ``covariance`` block (gpr_kinematics.core.geometry_covariance): ``gpr calibrate``
writes the fitted parameters' covariance, it reloads to the same matrix, the loader refuses a malformed block in one
line and takes a file without one as before."""
from __future__ import annotations

import json

import numpy as np
import pytest
from gpr_kinematics.calibration.core_model import calibrated_config_text
from gpr_kinematics.cli.main import main
from gpr_kinematics.core.config import load_config
from gpr_kinematics.core.geometry_covariance import GeometryCovariance, load_covariance, parse_covariance
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.inputs.resources import config_path

SHIPPED = str(config_path('calibration/synthetic_measurements.csv'))


def run(capsys, *argv):
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def test_the_calibrated_file_carries_the_fitted_parameters_covariance(capsys, tmp_path):
    path = tmp_path / 'again.yaml'
    status, out, err = run(capsys, 'calibrate', SHIPPED, '--output', str(path), '--json')
    assert status == 0, err
    d = json.loads(out)
    fitted = [p for p in d['parameters'] if p['status'] == 'fitted']
    cov = load_covariance(path)
    assert cov is not None and list(cov.names) == [p['name'] for p in fitted] == d['fitted']
    # the coordinates' standard errors of the report (a kappa's as its anisotropy)
    se = [p['coordinate']['standard_error'] if 'coordinate' in p else p['standard_error'] for p in fitted]
    np.testing.assert_allclose(np.sqrt(np.diag(cov.matrix)), se, rtol=1e-12)
    corr = cov.matrix / np.sqrt(np.outer(np.diag(cov.matrix), np.diag(cov.matrix)))
    np.testing.assert_allclose(corr, np.array(d['correlation']), atol=1e-9)
    assert '# covariance: of the 21 fitted parameters' in path.read_text()
    # the geometry as without the block (the same file's text up to it: a second fit of the same file, which this
    # compared with, differed in the last digits on one machine, 0.0932830457162 against 0.0932830457109 m)
    text = path.read_text()
    plain = tmp_path / 'plain.yaml'
    plain.write_text(text[:text.index('\ncovariance:\n') + 1])
    assert load_covariance(plain) is None and load_config(path) == load_config(plain)


def test_the_block_reloads_to_the_same_matrix(tmp_path):
    rng = np.random.default_rng(3)
    names = ('rod1_x', 'rod2_offset', 'rod3_uy', 'joint2_x', 'kappa1')
    A = rng.normal(size=(5, 5)) * np.array([1e-6, 2e-6, 1e-5, 3e-6, 1e-2])
    C = A @ A.T
    cfg = load_config()
    path = tmp_path / 'cal.yaml'
    path.write_text(calibrated_config_text(cfg, ('a test',), GeometryCovariance(names, C)))
    back = load_covariance(path)
    assert back is not None and back.names == names
    assert np.array_equal(back.matrix, C)                           # to the bit
    assert load_config(path) == cfg
    # a file without the block: as before
    plain = tmp_path / 'plain.yaml'
    plain.write_text(calibrated_config_text(cfg))
    assert load_covariance(plain) is None and load_config(plain) == cfg


GOOD = {'names': ['rod1_x', 'rod1_offset'], 'matrix': [[1e-12, 2e-13], [2e-13, 4e-12]]}


@pytest.mark.parametrize(('block', 'words'), [
    ('[1, 2]', 'covariance = [1, 2] (a list) is invalid; allowed: a mapping of names'),
    ("{names: [rod1_x]}", 'covariance: missing key matrix'),
    ("{names: [rod1_x], matrix: [[1e-12]], sigma: 1}", 'covariance: unknown key(s) sigma'),
    ("{names: [rod9_x], matrix: [[1e-12]]}", "names: unknown parameter 'rod9_x'; allowed: a list of distinct geometry"),
    ("{names: [rod1_x, rod1_x], matrix: [[1, 0], [0, 1]]}", 'names: rod1_x named twice'),
    ("{names: [], matrix: []}", 'names = [] is invalid'),
    ("{names: [rod1_x, rod1_y], matrix: [[1e-12, 0]]}", 'matrix = [[1e-12, 0]] is invalid (2 names); allowed: 2 rows'),
    ("{names: [rod1_x, rod1_y], matrix: [[1e-12, 0], [0]]}", 'matrix[1] (rod1_y) = [0] is invalid'),
    ("{names: [rod1_x, rod1_y], matrix: [[1e-12, .nan], [0, 1e-12]]}",
     'matrix[0][1] (rod1_x, rod1_y) = nan is invalid'),
    ("{names: [rod1_x], matrix: [[2.0e+6]]}", 'matrix[0][0] (rod1_x, rod1_x) = 2000000.0 is invalid; allowed: 1 rows '
                                             '(one per name) of 1 finite numbers each, of magnitude at most 1e+06'),
    ("{names: [rod1_x, rod1_y], matrix: [[1e-12, 1e-13], [3e-13, 1e-12]]}", 'matrix is not symmetric: (rod1_x, '
                                                                            'rod1_y) = 1e-13 but (rod1_y, rod1_x) = '
                                                                            '3e-13; allowed: a symmetric matrix'),
    ("{names: [rod1_x], matrix: [[-1e-12]]}", 'the variance of rod1_x is -1e-12'),
    ("{names: [rod1_x, rod1_y], matrix: [[1e-12, 2e-12], [2e-12, 1e-12]]}", 'the covariance of rod1_x and rod1_y is '
                                                                           '2e-12, beyond the square root'),
    ("{names: [rod1_x, rod1_y, rod2_x], matrix: [[1e-12, 9e-13, -9e-13], [9e-13, 1e-12, 9e-13], [-9e-13, 9e-13, "
     "1e-12]]}", 'matrix is not positive semi-definite (its correlation matrix has the eigenvalue -0.8)'),
    # a variance of 0 with a covariance (its correlation read in SI units had passed, and --robot printed NaN)
    ("{names: [rod1_offset, rod2_offset], matrix: [[0.0, 1.637e-09], [1.637e-09, 2.734e-09]]}",
     'the covariance of rod1_offset and rod2_offset is 1.637e-09, beyond the square root of their variances 0.0'),
    # asymmetric among small variances beside a large one (the check was relative to the largest entry)
    ("{names: [rod2_offset, rod3_offset, kappa1], matrix: [[3e-13, 1.8e-13, 0], [-1.8e-13, 3e-13, 0], [0, 0, 7.8e-4]]}",
     'matrix is not symmetric: (rod2_offset, rod3_offset) = 1.8e-13 but (rod3_offset, rod2_offset) = -1.8e-13'),
])
def test_a_malformed_block_is_refused_in_one_line(capsys, tmp_path, block, words):
    path = tmp_path / 'bad.yaml'
    path.write_text(f'radius: 0.093218\ncovariance: {block}\n')
    status, out, err = run(capsys, 'fk', '0.3', '0.3', '0.3', '--config', str(path))
    assert status == 2 and out == '' and err.count('\n') == 1 and 'Traceback' not in err, err
    assert f'{path}: covariance' in err and words in err and 'allowed' in err, err
    with pytest.raises(ValueError, match='covariance'):
        load_covariance(path)


def test_a_block_within_rounding_is_taken(tmp_path):
    """Symmetric and semi-definite within rounding: a rank-deficient covariance, its asymmetry 1e-12 relative."""
    v = np.array([1e-6, -2e-6, 3e-6])
    C = np.outer(v, v)
    C[0, 1] *= 1 + 1e-12
    path = tmp_path / 'ok.yaml'
    path.write_text('covariance:\n  names: [rod1_x, rod2_x, rod3_x]\n  matrix: '
                    + json.dumps(C.tolist()) + '\n')
    assert np.array_equal(load_covariance(path).matrix, C)
    load_config(path)
    good = tmp_path / 'good.yaml'
    good.write_text('covariance: ' + json.dumps(GOOD) + '\n')
    assert load_covariance(good).names == ('rod1_x', 'rod1_offset')


def test_tiny_variances_are_taken():
    """A reviewer's block with a variance of 1e-160 (the product of two such underflowed to 0 and the diagonal entry
    read as a covariance beyond its variances); a correlation beyond 1 between two of them is still refused."""
    C = np.array([[1e-160, 0.0], [0.0, 1e-12]])
    assert np.array_equal(parse_covariance({'names': ['rod1_x', 'rod1_y'], 'matrix': C.tolist()}, 'x.yaml').matrix, C)
    with pytest.raises(ConfigError, match='the covariance of rod1_x and rod1_y is 2e-160, beyond the square root'):
        parse_covariance({'names': ['rod1_x', 'rod1_y'], 'matrix': [[1e-160, 2e-160], [2e-160, 1e-160]]}, 'x.yaml')


def test_a_fit_forced_through_its_gate_writes_a_file_that_loads(capsys, tmp_path):
    """A poor fit written with --force (the sigmas 100x the noise, a tiny threshold: kappa1's anisotropy of variance
    5.2) wrote a block every loader then refused (entries at most 1): they are bounded by 1e6 now, and a block the
    loader would refuse is not written."""
    src = config_path('calibration/synthetic_measurements.csv').read_text().splitlines()
    rows = [line if line.startswith('#') else ','.join(line.split(',')[:10]) for line in src]
    meas = tmp_path / 'nosig.csv'
    meas.write_text('\n'.join(rows) + '\n')
    out = tmp_path / 'thr.yaml'
    run(capsys, 'calibrate', str(meas), '--sigma-position', '3e-4', '--sigma-angle', '3e-4', '--threshold', '1e-6',
        '--force', '--output', str(out), '--no-progress')
    cov = load_covariance(out)
    assert cov is not None and float(np.max(np.diag(cov.matrix))) > 1.0
    status, _, err = run(capsys, 'fk', '0.3', '0.3', '0.3', '--config', str(out))
    assert status == 0, err
