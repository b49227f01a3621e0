"""The parameters a tolerance table held at nominal, named where the chi-square fails (gpr_kinematics.calibration.held).

A trial's 40 planned poses of machines drawn from a table (rods 40 um, offsets 60 um, directions 0.1 mrad, joints 25
um, kappa 0.5 to 2) failed the gate at a reduced chi-square of 1.38 against 1.32, the refusal naming columns, frames
and noise, and parameters fixed by --free or a tolerance of 0, but not the six the table held: the poses see them,
less well than their tolerances, and within those they are off nominal by up to a tolerance."""
from __future__ import annotations

import numpy as np
import pytest
from gpr_kinematics.calibration.core_model import CoreModel
from gpr_kinematics.calibration.identification import identify
from gpr_kinematics.calibration.measurements import Measurements, read_measurements
from gpr_kinematics.calibration.tolerances import bound_of, parse_tolerances, prior_of
from gpr_kinematics.core.config import load_config
from gpr_kinematics.inputs.resources import config_path
from scipy.spatial.transform import Rotation

TABLE = {'units': {'length': 'mm', 'angle': 'rad'},
         'parameters': {'rod_positions': {'tolerance': 0.04}, 'rod_offsets': {'tolerance': 0.06},
                        'rod_directions': {'tolerance': 3.0e-4, 'distribution': 'normal'},
                        'platform_joints': {'tolerance': 0.025},
                        'kappa': {'range': [0.5, 2.0], 'distribution': 'log-uniform'}}}
HELD = ('Held at nominal by the --tolerances table, not by --free: joint3_x, joint2_x, joint1_y, rod1_x and 2 more '
        '(the poses see them less well than their tolerances: scaled singular values 0.38 to 0.719, under the '
        'threshold 1; within their tolerances they may still be off nominal by as much, which the chi-square '
        'counts). To fit them, lower --threshold below their scaled singular values or widen their tolerances in the '
        'table.')


@pytest.fixture(scope='module')
def drawn():
    """The trial's machine 4 (seed 1004) drawn from the table, measured at the shipped file's 40 planned rods with
    3 um and 20 urad of noise, declared."""
    core = CoreModel(load_config())
    ps = core.parameters
    q = read_measurements(str(config_path('calibration/synthetic_measurements.csv'))).q
    rng = np.random.default_rng(1004)
    v = ps.values(ps.nominal).copy()
    for i, n in enumerate(ps.names):
        if n.startswith('rod') and n.endswith(('_x', '_y')):
            v[i] += rng.uniform(-40e-6, 40e-6)
        elif n.endswith('_offset'):
            v[i] += rng.uniform(-60e-6, 60e-6)
        elif n.endswith(('_ux', '_uy')):
            v[i] += rng.normal(0, 1e-4)
        elif n.startswith('joint'):
            v[i] += rng.uniform(-25e-6, 25e-6)
        elif n.startswith('kappa'):
            v[i] = np.exp(rng.uniform(np.log(0.5), np.log(2.0)))
    pos, rot = core.poses(ps.coordinates(v)[None], q[None])
    p = pos[0] + rng.normal(0, 3e-6, pos[0].shape)
    R = Rotation.from_rotvec(rng.normal(0, 2e-5, p.shape)).as_matrix() @ rot[0]
    n = len(q)
    return core, Measurements('drawn.csv', q, p, Rotation.from_matrix(R).as_quat(), np.full(n, 3e-6),
                              np.full(n, 2e-5), tuple(range(2, n + 2)))


def _fit(drawn, table, **options):
    core, meas = drawn
    t = parse_tolerances(table, 't.yaml')
    return identify(core, meas, prior=prior_of(t, core.parameters), bound=bound_of(t, core.parameters), **options)


def test_a_failed_chi_square_names_the_parameters_the_table_held(drawn):
    """The six the table held while the poses see them are named (four, then how many more), with their scaled
    singular values and what to do; the three joint places the poses cannot see at all (1e-10 to 1e-5) are not the
    table's doing. A lower --threshold fits them, and the gate passes."""
    res = _fit(drawn, TABLE)
    check = next(c for c in res.gate.checks if c.name == 'chi_square')
    assert not check.passed and check.value == pytest.approx(1.34, abs=0.005), check
    assert res.identifiability.held == ('joint1_x', 'joint3_y', 'joint2_y', 'joint3_x', 'joint2_x', 'joint1_y',
                                        'rod1_x', 'rod3_y', 'rod2_y')
    assert check.detail.endswith('(--free, a tolerance of 0)? ' + HELD), check.detail
    assert HELD in res.gate.message()
    lower = _fit(drawn, TABLE, threshold=0.3)
    assert lower.gate.passed and lower.chi2_reduced == pytest.approx(1.165, abs=0.005), lower.gate.message()


def test_parameters_of_a_tolerance_of_0_are_named_and_not_those_fixed_by_free(drawn):
    """Offsets of tolerance 0 (exact) that are off nominal by up to 60 um: named as the table's, not the joints
    --free left out (the user's choice), and no parameter the table held where the fit passes (no table, or a
    passed chi-square)."""
    table = {**TABLE, 'parameters': {**TABLE['parameters'], 'rod_offsets': {'tolerance': 0.0}}}
    res = _fit(drawn, table, free=['rod_positions', 'rod_offsets', 'rod_directions', 'kappa'])
    check = next(c for c in res.gate.checks if c.name == 'chi_square')
    assert not check.passed and check.value > 10, check
    assert check.detail.endswith(
        'Held at nominal by the --tolerances table, not by --free: rod1_x, rod3_y, rod2_y (the poses see them less '
        'well than their tolerances: scaled singular values 0.652 to 0.721, under the threshold 1; within their '
        'tolerances they may still be off nominal by as much, which the chi-square counts); rod1_offset, '
        'rod2_offset, rod3_offset (a tolerance of 0: held exactly at nominal, which the chi-square counts if they '
        'are not there). To fit them, lower --threshold below their scaled singular values or widen their '
        'tolerances in the table.'), check.detail
    assert 'joint' not in check.detail.split('Held at nominal')[1], check.detail
    core, meas = drawn
    plain = identify(core, meas, free=['rod_positions', 'rod_directions', 'kappa'])
    assert 'Held at nominal by the --tolerances' not in plain.gate.message()
