"""Generalized Stewart platforms (Toz & Kucuk 2016): paper numbers, Jacobians, YAML."""
from __future__ import annotations

import math

import numpy as np
import pytest
import yaml
from gpr_kinematics.errors import ConfigError, InputError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.mechanisms import load_mechanism, mechanism_from_dict
from gpr_kinematics.mechanisms.base import euler_rate_matrix, euler_rotation, homogenize, rotation_from_vector
from gpr_kinematics.mechanisms.gsp import GeneralizedStewartPlatform, parse_constraint
from scipy.spatial.transform import Rotation

DEG = math.pi / 180


def twist_fd(mech, pose: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central differences of the inverse kinematics along each twist direction (w in the base frame)."""
    pose = np.asarray(pose, dtype=float).ravel()
    R0 = mech.rotation(pose)[0]
    cols = []
    for k in range(6):
        vals = []
        for sgn in (1.0, -1.0):
            p = pose.copy()
            if k < 3:
                p[k] += sgn * h
            else:
                w = np.zeros(3)
                w[k - 3] = sgn * h
                R = Rotation.from_rotvec(w).as_matrix() @ R0
                p[3:] = Rotation.from_matrix(R).as_euler(mech.euler_convention)
            vals.append(mech.inverse_kinematics(p))
        cols.append((vals[0] - vals[1]) / (2 * h))
    return np.stack(cols, axis=-1)


def test_d3_6_paper_leg_values():
    mech = load_mechanism(config_path('mechanisms/gsp_d3_6.yaml'))
    pose = np.array([10e-3, -10e-3, 138e-3, 5 * DEG, -5 * DEG, -10 * DEG])
    d = mech.inverse_kinematics(pose) * 1e3
    np.testing.assert_allclose(d, [143.909, 132.988, 155.211, 123.512, 126.31, 126.963], atol=6e-4)
    assert mech.joint_types == ('prismatic',) * 6
    assert mech.characteristic_length == pytest.approx(0.095)


def test_asymmetric_paper_values():
    mech = load_mechanism(config_path('mechanisms/gsp_d1d2d3d4a1a1.yaml'))
    pose = np.array([7e-3, -8e-3, 124e-3, 2 * DEG, 5 * DEG, -5 * DEG])
    q = mech.inverse_kinematics(pose)
    assert list(mech.types) == ['D1', 'D2', 'D3', 'D4', 'A1', 'A1']
    np.testing.assert_allclose(q[:3] * 1e3, [133.007, 87.5579, 130.427], atol=6e-4)
    np.testing.assert_allclose(np.degrees(q[4:]), [34.0845, 44.0236], atol=6e-5)
    # The D4 distance of leg 4 is not printed in the paper; it is the common-normal length of its lines.
    assert q[3] * 1e3 == pytest.approx(122.43089, abs=1e-4)
    # The file's reference block holds the same printed values.
    ref = yaml.safe_load(config_path('mechanisms/gsp_d1d2d3d4a1a1.yaml').read_text())['reference']
    np.testing.assert_allclose(ref['pose'], pose, atol=1e-15)


# The homogenised inverse Jacobians the paper prints, eqs. (24) and (25) (row 5 of (25) is printed with seven
# entries, 0 0 0 0 -0.08 -0.309 0.947: its three angular entries are the last three).
PRINTED_24 = [[0.243, 0.501, -0.829, 0.658, 0.462, 0.473], [0.231, -0.263, -0.936, -0.575, 0.726, -0.346],
              [-0.568, -0.046, -0.821, -0.726, 0.418, 0.479], [0.155, 0.361, -0.919, -0.346, -0.844, -0.39],
              [0.215, -0.401, -0.89, 0.05, -0.878, 0.408], [-0.46, -0.011, -0.887, 0.872, 0.072, -0.453]]
PRINTED_25 = [[-0.599, -0.457, 0.656, -0.084, -0.645, -0.527], [-0.106, 0.181, 0.977, 0.283, -0.781, 0.176],
              [-0.533, -0.026, -0.845, -0.458, 0.161, 0.284], [-0.08, -0.309, 0.947, 0.102, 0.311, 0.11],
              [0, 0, 0, -0.08, -0.309, 0.947], [0, 0, 0, 0.058, -0.294, -0.953]]


def test_printed_inverse_jacobians_differ_as_documented():
    """docs/mechanisms.md, 'What does not reproduce': (24) is close to the negative of ours (up to 0.094), condition
    number 3.06; in (25) the D1 and D2 rows' linear parts agree to 0.01-0.08, the D3 row is of opposite sign and
    the D4 and A1 rows differ by up to 0.14 (0.136, the D4 row's angular part; up to 0.104 elsewhere)."""
    d36 = load_mechanism(config_path('mechanisms/gsp_d3_6.yaml'))
    J24 = d36.homogenized_inverse_jacobian(np.array([10e-3, -10e-3, 138e-3, 5 * DEG, -5 * DEG, -10 * DEG]))
    assert np.max(np.abs(J24 + np.array(PRINTED_24))) == pytest.approx(0.094, abs=5e-4)
    assert d36.report(np.array([10e-3, -10e-3, 138e-3, 5 * DEG, -5 * DEG, -10 * DEG])).condition_number \
        == pytest.approx(3.06, abs=5e-3)
    asym = load_mechanism(config_path('mechanisms/gsp_d1d2d3d4a1a1.yaml'))
    J = asym.homogenized_inverse_jacobian(np.array([7e-3, -8e-3, 124e-3, 2 * DEG, 5 * DEG, -5 * DEG]))
    diff = np.abs(J - np.array(PRINTED_25))
    assert 0.005 < np.max(diff[:2, :3]) < 0.08
    assert np.max(np.abs(J[2] + np.array(PRINTED_25[2]))) < 0.025
    assert np.max(diff[3:]) == pytest.approx(0.136, abs=5e-4) and diff[3, 4] == np.max(diff[3:])
    assert np.max(np.delete(diff[3:].ravel(), 4)) == pytest.approx(0.104, abs=5e-4)
    # the unit common normal of leg 4's lines: ours (0.018, -0.239, 0.971), printed (-0.08, -0.309, 0.947)
    np.testing.assert_allclose(J[4, 3:], [0.018, -0.239, 0.971], atol=5e-4)


def test_euler_helpers_match_scipy_and_rates():
    rng = np.random.default_rng(3)
    ang = rng.uniform(-1, 1, (5, 3))
    for conv in ('xyz', 'ZXZ', 'YXZ', 'zyx'):
        np.testing.assert_allclose(euler_rotation(ang, conv), Rotation.from_euler(conv, ang).as_matrix(),
                                   atol=1e-14)
        E = euler_rate_matrix(ang, conv)
        h = 1e-6
        for k in range(3):
            d = np.zeros(3)
            d[k] = h
            dR = (euler_rotation(ang + d, conv) - euler_rotation(ang - d, conv)) / (2 * h)
            W = dR @ np.swapaxes(euler_rotation(ang, conv), -1, -2)
            w = np.stack([W[:, 2, 1], W[:, 0, 2], W[:, 1, 0]], -1)
            np.testing.assert_allclose(E[:, :, k], w, atol=1e-8)
    w = rng.normal(size=(4, 3))
    np.testing.assert_allclose(rotation_from_vector(w), Rotation.from_rotvec(w).as_matrix(), atol=1e-14)


def _random_mechanism(rng: np.random.Generator) -> GeneralizedStewartPlatform:
    """All five constraint types, random points on a 0.15 m base and a 0.08 m platform."""
    cons = []
    for k, ctype in enumerate(('D1', 'D2', 'D3', 'D4', 'A1', 'D3')):
        entry = {'type': ctype}
        pts = {'A_i': rng.uniform(-0.15, 0.15, 3) * [1, 1, 0.2], 'A_j': rng.uniform(-0.15, 0.15, 3),
               'B_i': rng.uniform(-0.08, 0.08, 3) * [1, 1, 0.2], 'B_j': rng.uniform(-0.08, 0.08, 3)}
        needed = {'D1': ('A_i', 'B_i'), 'D2': ('A_i', 'B_i', 'B_j'), 'D3': ('A_i', 'A_j', 'B_i'),
                  'D4': ('A_i', 'A_j', 'B_i', 'B_j'), 'A1': ('A_i', 'A_j', 'B_i', 'B_j')}[ctype]
        entry.update({key: pts[key].tolist() for key in needed})
        cons.append(parse_constraint(entry, f'c{k}'))
    return GeneralizedStewartPlatform(cons, characteristic_length=0.1)


@pytest.mark.parametrize('seed', [0, 1, 2])
def test_every_row_matches_finite_differences(seed):
    rng = np.random.default_rng(seed)
    mech = _random_mechanism(rng)
    poses = []
    for _ in range(4):
        pose = np.concatenate([rng.uniform(-0.02, 0.02, 2), [rng.uniform(0.1, 0.15)], rng.uniform(-0.3, 0.3, 3)])
        J = mech.inverse_jacobian(pose)              # one pose: the float-arithmetic path
        np.testing.assert_allclose(J, twist_fd(mech, pose[None, :].copy()), atol=2e-8)
        poses.append(pose)
    # The batch (numpy) path gives the same rows and joint values to rounding.
    poses = np.array(poses)
    np.testing.assert_allclose(mech.inverse_jacobian(poses), [mech.inverse_jacobian(p) for p in poses],
                               rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(mech.inverse_kinematics(poses), [mech.inverse_kinematics(p) for p in poses],
                               rtol=1e-14, atol=1e-16)


@pytest.mark.parametrize('name', ['gsp_d3_6.yaml', 'gsp_d1d2d3d4a1a1.yaml'])
def test_paper_mechanism_jacobians_match_finite_differences(name):
    mech = load_mechanism(config_path(f'mechanisms/{name}'))
    rng = np.random.default_rng(7)
    poses = np.column_stack([rng.uniform(-0.01, 0.01, (5, 2)), rng.uniform(0.12, 0.14, 5),
                             rng.uniform(-0.15, 0.15, (5, 3))])
    J = mech.inverse_jacobian(poses)
    for i in range(5):
        np.testing.assert_allclose(J[i], twist_fd(mech, poses[i:i + 1].copy()), atol=2e-8)
    # Batch and single agree.
    np.testing.assert_allclose(mech.inverse_jacobian(poses[2]), J[2], atol=0)


def test_d3_angular_term_as_printed_does_not_match():
    """The paper's eq. (14) angular part ((v x s) x Rb)/d differs from the derivative; ours matches."""
    mech = load_mechanism(config_path('mechanisms/gsp_d3_6.yaml'))
    pose = np.array([10e-3, -10e-3, 138e-3, 5 * DEG, -5 * DEG, -10 * DEG])
    R = mech.rotation(pose)[0]
    v = pose[:3] + mech.B_i @ R.T - mech.A_i
    Rb = mech.B_i @ R.T
    d = np.linalg.norm(np.cross(v, mech.s), axis=1)[:, None]
    printed = np.cross(np.cross(v, mech.s), Rb) / d
    fd = twist_fd(mech, pose[None, :].copy())
    assert np.max(np.abs(printed - fd[:, 3:])) > 1e-2
    np.testing.assert_allclose(mech.inverse_jacobian(pose)[:, 3:], fd[:, 3:], atol=2e-8)


def test_homogenization_and_conditioning():
    mech = load_mechanism(config_path('mechanisms/gsp_d1d2d3d4a1a1.yaml'))
    pose = np.array([7e-3, -8e-3, 124e-3, 2 * DEG, 5 * DEG, -5 * DEG])
    J = mech.inverse_jacobian(pose)
    H = mech.homogenized_inverse_jacobian(pose)
    L = 0.16
    np.testing.assert_allclose(H[:4, :3], J[:4, :3])
    np.testing.assert_allclose(H[:4, 3:], J[:4, 3:] / L)
    np.testing.assert_allclose(H[4:, 3:], J[4:, 3:])      # A1 rows: (L theta') per (L w)
    np.testing.assert_allclose(J[4:, :3], 0.0)
    sv = np.linalg.svd(H, compute_uv=False)
    assert mech.condition_number(pose)[0] == pytest.approx(sv[0] / sv[-1])
    assert mech.dexterity(pose)[0] == pytest.approx(sv[-1] / sv[0])
    assert not mech.is_singular(pose)[0]
    # Unit change invariance: the homogenised matrix does not depend on the length unit.
    Hmm = homogenize(J * np.array([1, 1, 1, 1e3, 1e3, 1e3]) * np.array([1e3] * 4 + [1, 1])[:, None] / 1e3,
                     mech.joint_types, L * 1e3)
    np.testing.assert_allclose(Hmm, H, atol=1e-12)


def _five_d1_and_an_a1() -> GeneralizedStewartPlatform:
    """Five D1 legs about the z axis and an A1 constraint whose lines are parallel (along z) at a level platform."""
    cons = [parse_constraint({'type': 'D1', 'A_i': [math.cos(a), math.sin(a), 0], 'B_i': [0.5 * math.cos(a),
                                                                                            0.5 * math.sin(a), 0]},
                             f'c{k}') for k, a in enumerate(np.linspace(0, 2 * math.pi, 6, endpoint=False)[:5])]
    cons.append(parse_constraint({'type': 'A1', 'A_i': [0, 0, 0], 'A_j': [0, 0, 1], 'B_i': [0, 0, 0],
                                  'B_j': [0, 0, 1]}, 'a1'))
    return GeneralizedStewartPlatform(cons)


def test_a1_singular_when_lines_parallel():
    """An A1 constraint with theta = 0 has no inverse-Jacobian row (division by sin theta)."""
    mech = _five_d1_and_an_a1()
    pose = np.array([0, 0, 1.0, 0, 0, 0])
    assert mech.inverse_kinematics(pose)[5] == 0.0
    assert not np.all(np.isfinite(mech.inverse_jacobian(pose)))
    assert mech.report(pose).singular
    tilted = np.array([0, 0, 1.0, 0.2, 0, 0])
    assert mech.inverse_kinematics(tilted)[5] == pytest.approx(0.2)
    np.testing.assert_allclose(mech.inverse_jacobian(tilted), twist_fd(mech, tilted[None].copy()), atol=2e-8)


def test_a1_keeps_every_digit_of_small_angles_and_its_row_stays_a_unit_vector():
    """``arccos(R t . s)`` lost a small angle's digits (1e-7 rad read 2.3 % low, 1e-8 read 0 and its row infinite:
    'the lines are parallel'; |R t x s| by its square underflowed below 1e-154): for the same mechanism turned by A
    about x, the A1 angle is A to rounding of A itself
    (the lines start parallel), in the batch and the one-pose paths, and its row ``-(R t x s) / sin(theta)`` has
    norm 1 (unit lines), no row said undefined."""
    mech = _five_d1_and_an_a1()
    angles = np.array([1e-3, 1e-5, 1e-6, 1e-7, 1e-8, 1.4e-8, 1e-12, -1e-9, math.pi - 1e-9, 1e-160, 1e-300])
    poses = np.column_stack([np.zeros((angles.size, 2)), np.ones(angles.size), angles, np.zeros((angles.size, 2))])
    batch = mech.inverse_kinematics(poses)[:, 5]
    one = np.array([mech.inverse_kinematics(p)[5] for p in poses])
    truth = np.where(angles > math.pi / 2, angles, np.abs(angles))   # the angle between the lines, in [0, pi]
    np.testing.assert_allclose(batch, truth, rtol=1e-15, atol=0)
    np.testing.assert_allclose(one, truth, rtol=1e-15, atol=0)
    rows = mech.inverse_jacobian(poses)[:, 5, 3:]
    np.testing.assert_allclose(np.linalg.norm(rows, axis=-1), 1.0, rtol=1e-15)
    assert list(mech.singularity(poses)) == [''] * angles.size   # no row undefined ('the lines are parallel')
    np.testing.assert_allclose(mech.inverse_jacobian(poses[0]), twist_fd(mech, poses[:1].copy()), atol=2e-8)


def _paper_dict() -> dict:
    return yaml.safe_load(config_path('mechanisms/gsp_d1d2d3d4a1a1.yaml').read_text())


def test_yaml_constraint_limits_are_the_joint_limits():
    """A constraint's ``limits: [min, max]`` become its joint's limits (min < max; an infinite end is no limit)."""
    data = _paper_dict()
    data['constraints'][0]['limits'] = [0.5, 2.5]
    data['constraints'][1]['limits'] = [0.0, math.inf]
    limits = np.asarray(mechanism_from_dict(data, 'x.yaml').joint_limits)
    assert limits[0].tolist() == [0.5, 2.5] and limits[1].tolist() == [0.0, math.inf]


def test_yaml_ignores_workspace_section():
    data = _paper_dict()
    data['workspace'] = {'box': {'z': [0, 1]}}
    mech = mechanism_from_dict(data, 'x.yaml')
    assert mech.n_joints == 6


@pytest.mark.parametrize('mutate, match', [
    (lambda d: d['constraints'][0].update(type='D7'), r"x\.yaml: constraints\[0\]\.type = 'D7'.*allowed: D1"),
    (lambda d: d['constraints'][2].update(A_j=d['constraints'][2]['A_i']),
     r'constraints\[2\]: degenerate base line K'),
    (lambda d: d['constraints'][1].update(B_j=d['constraints'][1]['B_i']),
     r'constraints\[1\]: degenerate platform line L'),
    (lambda d: d['constraints'][0].update(A_j=[0, 0, 0]), r'constraints\[0\]: a D1 constraint takes the points '
                                                          r'A_i, B_i; got the extra point\(s\) A_j'),
    (lambda d: d['constraints'][3].pop('B_j'), r'constraints\[3\]: a D4 constraint needs .* missing B_j'),
    (lambda d: d['constraints'][0].update(B_i=[1, 2]), r'constraints\[0\]\.B_i must be a point \[x, y, z\]'),
    (lambda d: d['constraints'].pop(), r'exactly 6 constraints; got 5'),
    (lambda d: d.update(characteristic_length=-1),
     r'x.yaml: characteristic_length = -1; allowed: a length from 1e-06 to 1e\+06 m'),
    (lambda d: d.update(euler='xxz'), r'euler: Euler convention must be three axes'),
    (lambda d: d.update(colour='red'), r"unknown key\(s\) colour"),
    (lambda d: d.update(type='hexapod'), r"type = 'hexapod' is not a mechanism type"),
    (lambda d: d['constraints'][0].update(limits=[2.0, 1.0]),
     r'constraints\[0\]\.limits must be \[min, max\] with min < max'),
    (lambda d: d['constraints'][0].update(limits=[1.5, 1.5]),
     r'constraints\[0\]\.limits must be \[min, max\] with min < max'),
    (lambda d: d['constraints'][0].update(limits=[1.0]), r'constraints\[0\]\.limits must be \[min, max\]'),
    (lambda d: d['constraints'][0].update(limits=[1.0, 'x']), r'constraints\[0\]\.limits must be \[min, max\]'),
])
def test_yaml_errors_name_file_key_and_value(mutate, match):
    data = _paper_dict()
    mutate(data)
    with pytest.raises(ConfigError, match=match):
        mechanism_from_dict(data, 'x.yaml')


def test_load_errors(tmp_path):
    with pytest.raises(ConfigError, match='not found'):
        load_mechanism(tmp_path / 'missing.yaml')
    bad = tmp_path / 'bad.yaml'
    bad.write_text('type: gsp\nconstraints: [\n')
    with pytest.raises(ConfigError, match='bad.yaml: not valid YAML'):
        load_mechanism(bad)
    with pytest.raises(InputError, match=r'shape \(6,\) or \(N, 6\)'):
        load_mechanism(config_path('mechanisms/gsp_d3_6.yaml')).inverse_kinematics([1, 2, 3])


@pytest.mark.parametrize('points', [np.full((6, 3), 1e-300), np.zeros((6, 3))])
def test_with_parameters_refuses_a_line_without_direction(points):
    """A_i of 1e-300 gave inverse kinematics of inf, A_i = 0 of zeros: the file's check now holds here too."""
    from gpr_kinematics.errors import InputError
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.mechanisms import load_mechanism

    gsp = load_mechanism(config_path('mechanisms/gsp_d3_6.yaml'))
    with pytest.raises(InputError, match=r'constraint 1: degenerate base line K: A_j = .* coincides with A_i'):
        gsp.with_parameters({'A_i': points})


def _parallel_d4() -> GeneralizedStewartPlatform:
    """Five SPS legs and a D4 constraint whose lines (the z axis; the platform line through (0.1, 0, 0), along z)
    are parallel at rotation zero."""
    cons = [parse_constraint({'type': 'D1', 'A_i': [math.cos(a), math.sin(a), 0],
                              'B_i': [0.5 * math.cos(a), 0.5 * math.sin(a), 0]}, f'c{k}')
            for k, a in enumerate(np.linspace(0, 2 * math.pi, 5, endpoint=False))]
    cons.append(parse_constraint({'name': 'd4', 'type': 'D4', 'A_i': [0, 0, 0], 'A_j': [0, 0, 1],
                                  'B_i': [0.1, 0, 0], 'B_j': [0.1, 0, 1]}, 'd4'))
    return GeneralizedStewartPlatform(cons)


@pytest.mark.filterwarnings('error')
def test_d4_of_parallel_lines_is_their_distance_and_its_row_is_named_undefined():
    """Parallel D4 lines gave d4 = inf in one pose ('d4 = inf m is outside its limits [0, inf] m') and NaN with a
    RuntimeWarning in a batch. The distance of parallel lines is |v x s| (0.1 m here, and 0.1 m with the platform
    turned about z, which keeps them parallel); its rate is not defined (the common normal is not), which
    singularity() and the pose analysis name."""
    from gpr_kinematics.errors import SingularityError
    from gpr_kinematics.mechanisms.pose_analysis import analyse_pose
    mech = _parallel_d4()
    pose = np.array([0, 0, 1.0, 0, 0, 0])
    assert mech.inverse_kinematics(pose)[5] == pytest.approx(0.1, abs=1e-15)
    batch = mech.inverse_kinematics(np.array([pose, [0, 0, 1.0, 0, 0, 0.3], [0, 0, 1.0, 0.2, 0, 0]]))
    np.testing.assert_allclose(batch[:, 5], [0.1, 0.1, 0.1], atol=1e-15)
    # next to it the common normal's length: 0.1 m about x (lines in parallel planes), 0 about y (they cross)
    assert mech.inverse_kinematics([0, 0, 1.0, 1e-6, 0, 0])[5] == pytest.approx(0.1, abs=1e-12)
    assert mech.inverse_kinematics([0, 0, 1.0, 0, 1e-6, 0])[5] == pytest.approx(0.0, abs=1e-12)
    named = mech.singularity(np.array([pose, [0, 0, 1.0, 0.2, 0, 0]]))
    assert named.tolist() == ['d4 (D4): the lines K and L are parallel (R t x s = 0): their distance d = |v x s| '
                              "is defined, their common normal, and so d's rate, is not", '']
    assert mech.report(pose).singular and mech.report(pose).within_limits
    with pytest.raises(SingularityError, match=r'not defined at pose \[0\.0, 0\.0, 1\.0, 0\.0, 0\.0, 0\.0\] '
                                               r'\(d4 \(D4\): the lines K and L are parallel .*\); allowed: poses '
                                               r'where every row is defined'):
        analyse_pose(mech, pose)
    assert analyse_pose(mech, [0, 0, 1.0, 0.2, 0, 0]).joints[5].value == pytest.approx(0.1)


@pytest.mark.filterwarnings('error')
def test_a_dexterity_map_computes_the_inverse_jacobian_once_with_the_same_results(monkeypatch):
    """A GSP's dexterity map computed the inverse Jacobian twice per pose: for the conditioning and again in
    singularity() (about 20 % of the map). jacobian_and_singularity gives both from one, bit for bit as the two
    calls (a sweep of roll through the parallel D4 lines, exactly singular at A = 0, and a grid of the paper's GSP)."""
    from gpr_kinematics.mechanisms.dexterity import dexterity_grid, dexterity_sweep
    parallel, paper = _parallel_d4(), load_mechanism(config_path('mechanisms/gsp_d1d2d3d4a1a1.yaml'))
    calls = []
    rows = GeneralizedStewartPlatform.inverse_jacobian_rt
    monkeypatch.setattr(GeneralizedStewartPlatform, 'inverse_jacobian_rt',
                        lambda self, pos, R: calls.append(pos.shape[0]) or rows(self, pos, R))
    sweep = dexterity_sweep(parallel, [0, 0, 1.0, 0, 0, 0], 'A', np.linspace(-0.2, 0.2, 9))
    grid = dexterity_grid(paper, [0.007, -0.008, 0.124, 2 * DEG, 5 * DEG, -5 * DEG], 'x', np.linspace(-0.02, 0.02, 5),
                          'C', np.linspace(-0.3, 0.3, 4))
    assert calls == [9, 20]                    # one inverse Jacobian per map (it was [9, 9, 20, 20])
    assert sweep.singular.tolist() == [False] * 4 + [True] + [False] * 4 and sweep.dexterity[4] == 0.0
    assert np.isinf(sweep.condition_number[4]) and not grid.singular.any()
    for mech, poses in ((parallel, sweep.poses), (paper, grid.poses.reshape(-1, 6)), (paper, grid.poses[0, :1])):
        Jh, named = mech.jacobian_and_singularity(poses)
        with np.errstate(divide='ignore', invalid='ignore'):
            before = mech.homogenized_task_jacobian(poses)
        assert np.array_equal(Jh, before, equal_nan=True) and named.tolist() == mech.singularity(poses).tolist()
    assert parallel.jacobian_and_singularity(sweep.poses)[1][4].startswith('d4 (D4): the lines K and L are parallel')


def test_with_parameters_names_the_one_constraint_whose_line_has_no_direction():
    """One degenerate line among six (constraint 4's A_i moved onto its A_j) is refused, naming that constraint;
    moving A_i along its line (two distinct points still) is accepted, and only that joint's value changes."""
    gsp = load_mechanism(config_path('mechanisms/gsp_d3_6.yaml'))
    a, a_j = gsp.parameters()['A_i'], gsp.parameters()['A_j']
    bad = a.copy()
    bad[3] = a_j[3]
    with pytest.raises(InputError, match=r'constraint 4: degenerate base line K: A_j = .* coincides with A_i'):
        gsp.with_parameters({'A_i': bad})
    moved = a.copy()
    moved[3] = a[3] + 0.5 * (a_j[3] - a[3])
    pose = np.array([0.0, 0.0, 0.3, 0.1, -0.05, 0.2])
    before, after = gsp.inverse_kinematics(pose), gsp.with_parameters({'A_i': moved}).inverse_kinematics(pose)
    assert np.all(np.isfinite(after)) and np.array_equal(np.delete(before, 3), np.delete(after, 3))


def test_dexterity_of_small_wide_zero_and_ill_conditioned_matrices():
    """The inverse condition number sigma_min / sigma_max of matrices whose singular values are known: a wide one
    (the SVD path) scaled far below 1, U diag(1, 0.5, 1e-7) V^T (beyond the Gram estimate's limit: recomputed by
    SVD), a zero matrix (singular: 0)."""
    from gpr_kinematics.mechanisms.conditioning import condition_number, dexterity_index
    wide = 1e-3 * np.array([[[1.0, 0.0, 0.0], [0.0, 4.0, 0.0]]])              # sigma = 4e-3, 1e-3
    np.testing.assert_allclose(dexterity_index(wide), [0.25], rtol=1e-14)
    u, _ = np.linalg.qr(np.array([[2.0, 1.0, 0.5], [0.3, -1.0, 2.0], [1.0, 0.7, -0.4]]))
    v, _ = np.linalg.qr(np.array([[1.0, -2.0, 0.1], [0.6, 0.2, 1.5], [-1.1, 0.9, 0.8]]))
    # sigma 1, 0.5, 1e-7 (to 1e-16 absolute: 1e-9 relative on the least); the Gram estimate is 0.5 % off there
    ill = np.stack([u @ np.diag([1.0, 0.5, 1e-7]) @ v.T, np.diag([1.0, 0.5, 0.25])])
    np.testing.assert_allclose(dexterity_index(ill), [1e-7, 0.25], rtol=1e-7)
    np.testing.assert_allclose(condition_number(ill), [1e7, 4.0], rtol=1e-7)
    assert dexterity_index(np.zeros((1, 2, 3))).tolist() == [0.0]
    assert dexterity_index(np.zeros((1, 3, 3))).tolist() == [0.0] and condition_number(np.zeros((1, 3, 3)))[0] == np.inf

    # an exactly zero row of a square matrix: sigma_min is 0, rounding left 1e-17 of it (cond 6.2e16 reported)
    zero_row = np.array([[[0.8, -0.5, 0.3], [0.0, 0.0, 0.0], [0.1, 0.9, -0.2]]])
    assert dexterity_index(zero_row).tolist() == [0.0] and condition_number(zero_row)[0] == np.inf
    assert dexterity_index(np.swapaxes(zero_row, -1, -2)).tolist() == [0.0]   # a zero column
    assert dexterity_index(np.array([[[1.0, 0.0], [0.0, 0.0], [0.0, 2.0]]])).tolist() == [0.5]   # tall: rank 2


def test_crossing_d4_lines_give_a_zero_row_an_infinite_condition_number_and_a_named_singularity():
    """``gsp_d1d2d3d4a1a1.yaml`` at the zero pose: the D4 lines cross (d4 = 0) and the D4 row is all zeros, but the
    condition number was 6.156e16 and the singularity none."""
    from gpr_kinematics.mechanisms.pose_analysis import analyse_pose
    mech = load_mechanism(config_path('mechanisms/gsp_d1d2d3d4a1a1.yaml'))
    res = analyse_pose(mech, [0.0] * 6)
    assert res.joints[3].value == 0.0 and not np.any(res.inverse_jacobian[3])
    assert res.condition_number == np.inf and res.dexterity == 0.0 and res.singular
    assert res.singularity == 'd4 (D4): the lines K and L cross (d = 0): its row is zero, the rate of d = |f| / g is ' \
        'not defined'
    J, named = mech.jacobian_and_singularity(np.zeros((1, 6)))   # a dexterity map's: the same
    assert named.tolist() == [res.singularity] and mech.dexterity(np.zeros((1, 6))).tolist() == [0.0]


def test_a_constraint_given_twice_is_refused_naming_the_file(tmp_path):
    """Two identical D1 constraints loaded and every pose came out 'singular: yes' without a reason; refused at load,
    naming the file and both constraints."""
    from gpr_kinematics.errors import ConfigError
    from gpr_kinematics.mechanisms import load_mechanism

    rows = [([0.1, 0, 0], [0.05, 0, 0]), ([0.1, 0, 0], [0.05, 0, 0]), ([-0.1, 0, 0], [-0.05, 0, 0]),
            ([0, -0.1, 0], [0, -0.05, 0]), ([0.1, 0.1, 0], [0.05, 0.05, 0]), ([-0.1, 0.1, 0], [-0.05, 0.05, 0])]
    text = 'type: gsp\nname: coinc\nconstraints:\n' + ''.join(f'  - {{type: D1, A_i: {a}, B_i: {b}}}\n'
                                                              for a, b in rows)
    path = tmp_path / 'coinc.yaml'
    path.write_text(text)
    with pytest.raises(ConfigError, match=r'coinc\.yaml: coinc: constraints 1 and 2 are one D1 between the same '
                                          r'points'):
        load_mechanism(path)
    path.write_text(text.replace('B_i: [0.05, 0, 0]}', 'B_i: [0.05, 0, 0.01]}', 1))  # one platform joint apart
    assert load_mechanism(path).name == 'coinc'


def test_parameters_of_a_mixed_gsp_round_trip_and_take_errors_on_the_points_it_has():
    """The D1D2D3D4A1^2 platform's ``A_j``/``B_j`` are NaN for the constraints without them: ``with_parameters``
    refused its own ``parameters()`` (so no accuracy analysis took an error on a line's point); the NaN rows are now
    ignored, the constraints follow the points, an error on a point the mechanism has agrees with the exact solve to
    first order, one on a point it lacks is refused, and two constraints made one are refused as in a file."""
    from gpr_kinematics.mechanisms.accuracy import accuracy_analysis
    path = config_path('mechanisms/gsp_d1d2d3d4a1a1.yaml')
    gsp = load_mechanism(path)
    pose = yaml.safe_load(path.read_text())['reference']['pose']
    same = gsp.with_parameters(gsp.parameters())
    assert np.array_equal(same.inverse_kinematics(pose), gsp.inverse_kinematics(pose))
    moved = gsp.parameters()['A_j']
    assert np.isnan(moved[0]).all() and np.isfinite(moved[3]).all()
    moved[3, 0] += 1e-3
    moved[0] = 5.0                                   # constraint 1 (D1) has no A_j: ignored
    out = gsp.with_parameters({'A_j': moved})
    assert out.constraints[3].A_j.tolist() == moved[3].tolist() and out.constraints[0].A_j is None
    assert np.isnan(out.parameters()['A_j'][:2]).all()    # the constraints without A_j still have none
    assert out.constraints[3].A_j.tolist() != gsp.constraints[3].A_j.tolist()   # the original is untouched
    error = np.zeros((6, 3))
    error[3, 0] = 1e-6
    res = accuracy_analysis(gsp, [pose], np.zeros(6), {'A_j': error})
    assert np.max(np.abs(res.linearized[0])) > 1e-8
    np.testing.assert_allclose(res.exact[0], res.linearized[0], atol=1e-3 * np.max(np.abs(res.linearized[0])))
    for value in (1e-6, -1e-6):
        error[0, 1] = value
        with pytest.raises(InputError, match=rf'error of parameter A_j: value 2 of 18 is {value:g} for a point this '
                                             r'mechanism does not have .*allowed: 0 there'):
            accuracy_analysis(gsp, [pose], np.zeros(6), {'A_j': error})
    twice = gsp.parameters()
    for key in twice:
        twice[key][5] = twice[key][4]
    with pytest.raises(InputError, match=r'constraints 5 and 6 \(theta4, theta5\) are one A1 between the same points'):
        gsp.with_parameters(twice)


def test_the_exact_deviation_follows_its_branch_and_is_refused_where_it_ends():
    """A solve from the nominal pose alone converged on another assembly branch: the paper's GSP at its pose under an
    A1 error of 0.5 deg read 45 mm and 21 deg off (exit 0), where 0.4 deg was refused, because the branch through
    the nominal pose ends (a fold) near 0.357 deg; 8 equal steps still jumped to a branch of the same det sign
    (theta5 0.5 deg, d1 -10 mm). Followed as the error grows, 0.3 deg is solved on its branch (its Jacobian's
    determinant of the nominal's sign, the deviation continuous with 0.1 and 0.2 deg and second order off the
    linearised one) and 0.5 deg refused where the path ends (71.4 % of it; theta5's at 45.9 %, d1's at 15.1 %, as
    1,024 equal steps find)."""
    from gpr_kinematics.errors import ConvergenceError
    from gpr_kinematics.mechanisms.accuracy import accuracy_analysis
    gsp = load_mechanism(config_path('mechanisms/gsp_d1d2d3d4a1a1.yaml'))
    pose = np.array([7e-3, -8e-3, 0.124, 2 * DEG, 5 * DEG, -5 * DEG])
    q = gsp.inverse_kinematics(pose)
    det0 = np.linalg.det(gsp.task_jacobian(pose[None]))[0]

    def error(deg: float) -> np.ndarray:
        e = np.zeros(6)
        e[4] = deg * DEG
        return e

    jumped = gsp.forward_kinematics((q + error(0.5))[None], pose[None], tol=1e-13)[0]   # the solve of before
    assert np.linalg.norm(jumped[:3] - pose[:3]) > 0.04
    for k, value, share in ((4, 0.5 * DEG, '71.4'), (5, 0.5 * DEG, '45.8'), (0, -0.01, '15.1')):
        e = np.zeros(6)
        e[k] = value
        with pytest.raises(ConvergenceError, match=r'followed from the nominal pose as its errors grow, forward '
                                                   rf'kinematics at {share}\d* % of them'):
            accuracy_analysis(gsp, pose, e)
    deviations = [accuracy_analysis(gsp, pose, error(d)) for d in (0.1, 0.2, 0.3)]
    x = [r.exact[0] for r in deviations]
    assert all(np.sign(np.linalg.det(gsp.task_jacobian(r.exact_poses))[0]) == np.sign(det0) for r in deviations)
    assert np.linalg.norm(x[2] - x[1]) < 2.0 * np.linalg.norm(x[1] - x[0]) + 1e-3   # no jump between the steps
    lin = deviations[0].linearized[0]
    assert np.linalg.norm(x[0] - lin) < 0.2 * np.linalg.norm(lin)   # second order at 0.1 deg
    np.testing.assert_allclose(gsp.inverse_kinematics(deviations[2].exact_poses[0]), q + error(0.3), atol=1e-12)


def test_a_refused_pose_among_thousands_is_named_at_once(monkeypatch):
    """The pose refused was found by following every pose alone until one failed: 20,000 poses of which the last
    cannot be solved took 116 s (a file of 350,000 about half an hour), a solve per pose; halving the batch names
    it in a few dozen solves (counted)."""
    from gpr_kinematics.errors import ConvergenceError
    from gpr_kinematics.mechanisms.accuracy import accuracy_analysis
    stewart = load_mechanism(config_path('mechanisms/stewart_alwan.yaml'))
    solves = []
    real = type(stewart).forward_kinematics
    monkeypatch.setattr(type(stewart), 'forward_kinematics',
                        lambda self, *a, **k: solves.append(1) or real(self, *a, **k))
    poses = np.tile([0.0, 0.0, 1.8, 0.1, 0.2, 0.3], (5000, 1))
    poses[-1] = [0.0, 0.0, 0.001, 0.0, 0.0, 0.0]   # 1 mm above the base
    with pytest.raises(ConvergenceError, match=r'the exact deviation at pose 5000 \(x, y, z, A, B, C = 0, 0, 0.001'):
        accuracy_analysis(stewart, poses, np.array([1e-3, 0, 0, 0, 0, 0]))
    assert len(solves) < 60, len(solves)   # 12 halvings of the step, 13 of the batch (a solve per pose before)
