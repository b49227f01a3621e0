"""One machine per row: forward_batch with per-row geometry parameters (MachineGeometry.per_row) gives, row by
row, what one config per call gives; rows shared by blocks of samples; every row checked like a geometry file."""
import math
import warnings

import numpy as np
import pytest
from gpr_kinematics.core import forward_batch, naive_inverse
from gpr_kinematics.core.config import MODELS, load_config
from gpr_kinematics.core.machine import MachineGeometry, config_with_parameters, parameter_vector
from gpr_kinematics.core.parameters import PARAMETER_NAMES
from gpr_kinematics.errors import InputError, LimitError

CFG = load_config()
#: Per parameter kind: deviations of the size calibration finds (tens of um, 0.1 mrad), kappa from 0.1 to 10.
SIZES = np.array([3e-5, 3e-5, 4e-5, 1e-4, 1e-4, 3e-5, 3e-5, 0.0] * 3)


def machines(n, seed):
    rng = np.random.default_rng(seed)
    P = parameter_vector(CFG) + rng.normal(size=(n, 24)) * SIZES
    P[:, 7::8] = np.exp(rng.uniform(-2.3, 2.3, (n, 3)))
    Q = naive_inverse(rng.uniform(0.05, 0.45, n), rng.uniform(-1, 1, n) * CFG.tilt_limit, rng.uniform(-3, 3, n), CFG)
    return P, Q


@pytest.mark.parametrize('model', MODELS)
def test_each_row_is_its_own_machine(model):
    P, Q = machines(40, 1)
    fb = forward_batch(Q, CFG, model, check_limits=False, parameters=P)
    for i in range(40):
        one = forward_batch(Q[i:i + 1], config_with_parameters(CFG, P[i]), model, check_limits=False)
        for name in ('position', 'rotation', 'virtual_joints', 'nominal_position', 'centre_shift',
                     'joint_displacement', 'side_lengths'):
            np.testing.assert_allclose(getattr(fb, name)[i], getattr(one, name)[0], rtol=0, atol=5e-16, err_msg=name)
    assert fb.fit_residual.max() < 1e-13 and fb.residual.max() <= CFG.tolerance


def test_a_subset_of_parameters_and_blocks_of_samples():
    P, Q = machines(6, 2)
    names = ['rod1_offset', 'joint2_y', 'kappa3']
    cols = [PARAMETER_NAMES.index(n) for n in names]
    cfg = CFG.replace(model='compliant')
    # 3 machines, each at the same 2 configurations: row j serves samples 2j and 2j + 1
    QQ = np.repeat(Q[:2][None], 3, axis=0).reshape(6, 3)
    fb = forward_batch(QQ, cfg, parameters=P[:3, cols], names=names)
    for j in range(3):
        one = forward_batch(Q[:2], config_with_parameters(cfg, P[j, cols], names))
        np.testing.assert_allclose(fb.position[2 * j:2 * j + 2], one.position, rtol=0, atol=5e-16)
        np.testing.assert_allclose(fb.rotation[2 * j:2 * j + 2], one.rotation, rtol=0, atol=5e-16)
    # nominal values per row reproduce the config's own machine (which takes the closed-form nominal path)
    same = forward_batch(Q, cfg, parameters=np.repeat(parameter_vector(cfg)[None], 6, axis=0))
    np.testing.assert_allclose(same.position, forward_batch(Q, cfg).position, rtol=0, atol=1e-16)


def test_limits_apply_per_row():
    """The tilt check uses each row's machine: an offset of 6 mm on rod 1 tilts an otherwise level platform."""
    q = np.full((2, 3), 0.3)
    P = np.repeat(parameter_vector(CFG)[None], 2, axis=0)
    P[1, PARAMETER_NAMES.index('rod1_offset')] = 0.006
    with pytest.raises(LimitError, match=r'q = \[0\.3, 0\.3, 0\.3\] m \(sample 1\) tilts the platform by about '
                                         r'0\.04\d+ rad \(2\.\d+ deg\) in the naive model, beyond the tilt limit '
                                         r'0\.03491 rad \(2 deg\)'):
        forward_batch(q, CFG, parameters=P)
    tilt = forward_batch(q, CFG, parameters=P, check_limits=False).tilt
    assert tilt[0] == 0.0 and tilt[1] == pytest.approx(math.atan(0.006 / (1.5 * CFG.radius)), rel=1e-3)


def test_rows_are_checked_like_a_geometry_file():
    P = np.repeat(parameter_vector(CFG)[None], 3, axis=0)
    bad = P.copy()
    bad[2, PARAMETER_NAMES.index('kappa2')] = -1.0
    with pytest.raises(InputError, match=r'per-row geometry, row 2: kappa2 = -1\.0 is outside \[1e-06, 1e\+06\] '
                                         r'\(kappa: one number or a list of 3'):
        MachineGeometry.per_row(CFG, bad)
    bad = P.copy()
    bad[1, PARAMETER_NAMES.index('rod3_uy')] = np.nan
    with pytest.raises(InputError, match=r'row 1: rod3_uy = nan is not a finite number'):
        forward_batch(np.full((3, 3), 0.3), CFG, parameters=bad)
    bad = P.copy()
    bad[0, PARAMETER_NAMES.index('joint1_x')] += 0.01
    with pytest.raises(InputError, match=r'row 0: side 1-2 of the joint triangle is .* within 1% of each other'):
        MachineGeometry.per_row(CFG, bad)
    bad = P.copy()
    bad[1, PARAMETER_NAMES.index('rod2_x')], bad[1, PARAMETER_NAMES.index('rod2_y')] = P[0, 0], P[0, 1] + 1e-3
    with pytest.raises(InputError, match=r'row 1: the triangle of rod_positions has an angle of .* deg; allowed: '
                                         r'every angle >= 5 deg'):
        MachineGeometry.per_row(CFG, bad)
    bad = P.copy()   # every point at one place: no angle to refuse (a NaN closure and numpy's warnings followed)
    bad[1, [PARAMETER_NAMES.index(f'{s}{k}_{c}') for s in ('rod', 'joint') for k in (1, 2, 3) for c in 'xy']] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        with pytest.raises(InputError, match=r'row 1: the triangle of rod_positions has an angle of 0 deg; allowed'):
            forward_batch(np.full((3, 3), 0.3), CFG, parameters=bad)
    with pytest.raises(InputError, match=r'per-row geometry needs values of shape \(N, 2\)'):
        MachineGeometry.per_row(CFG, [[0.0, 0.0, 0.0]], ['rod1_x', 'rod1_y'])
    with pytest.raises(InputError, match=r'3 parameter rows for 4 rod-length rows'):
        forward_batch(np.full((4, 3), 0.3), CFG, parameters=P)
    with pytest.raises(InputError, match=r'unknown geometry parameter\(s\) rod4_x'):
        forward_batch(np.full((1, 3), 0.3), CFG, parameters=[[0.0]], names=['rod4_x'])


def test_joint_play_moves_the_joint_centres():
    """A displacement d of joint centre P_k (the play of its joint) is the machine whose rod k stands at
    B_k + (d_x, d_y) - d_z / u_kz (u_kx, u_ky) with the zero offset o_k + d_z / u_kz: the same poses, whether the
    geometry is the config's or one per row."""
    P, Q = machines(8, 5)
    rng = np.random.default_rng(6)
    d = rng.normal(0.0, 2e-5, (8, 3, 3))
    cfg = CFG.replace(model='compliant')
    for rows in (None, P):
        fb = forward_batch(Q, cfg, parameters=rows, displacement=d)
        for i in range(8):
            v = dict(zip(PARAMETER_NAMES, (parameter_vector(cfg) if rows is None else rows[i]).tolist(), strict=True))
            for k in (1, 2, 3):
                uz = math.sqrt(1 - v[f'rod{k}_ux'] ** 2 - v[f'rod{k}_uy'] ** 2)
                along = d[i, k - 1, 2] / uz
                v[f'rod{k}_offset'] += along
                v[f'rod{k}_x'] += d[i, k - 1, 0] - along * v[f'rod{k}_ux']
                v[f'rod{k}_y'] += d[i, k - 1, 1] - along * v[f'rod{k}_uy']
            one = forward_batch(Q[i:i + 1], config_with_parameters(cfg, list(v.values())))
            np.testing.assert_allclose(fb.position[i], one.position[0], rtol=0, atol=1e-15)
            np.testing.assert_allclose(fb.rotation[i], one.rotation[0], rtol=0, atol=1e-15)
    moved = forward_batch(Q, cfg, displacement=np.broadcast_to([1e-5, -2e-5, 3e-5], (8, 3, 3)))
    np.testing.assert_allclose(moved.position - forward_batch(Q, cfg).position, np.broadcast_to([1e-5, -2e-5, 3e-5],
                                                                                                 (8, 3)), atol=1e-15)
    with pytest.raises(InputError, match=r'joint displacements must have shape \(8, 3, 3\), one \(3, 3\) per sample'):
        forward_batch(Q, cfg, displacement=np.zeros((2, 3, 3)))
    with pytest.raises(InputError, match=r'joint displacement \[0, 0, 0\] = nan m; allowed: finite, within'):
        forward_batch(Q, cfg, displacement=np.full((8, 3, 3), np.nan))


@pytest.mark.parametrize(('call', 'message'), [
    (lambda: forward_batch(np.full((1, 3), 0.3), CFG, parameters='x'),
     "per-row geometry values must be numbers [SI], got 'x'"),
    (lambda: forward_batch(np.full((1, 3), 0.3), CFG, parameters=[[10 ** 400]], names=['rod1_x']),
     'per-row geometry values must be numbers [SI], got [[<an integer of about 401 digits>]]'),
    (lambda: forward_batch(np.full((2, 3), 0.3), CFG, displacement=[np.zeros((3, 3)), np.zeros((2, 3))]),
     'joint displacements must be numbers [m], shape (2, 3, 3), got [array('),
    (lambda: forward_batch(np.full((1, 3), 0.3), CFG, parameters=[[0.0]], names='rod1_x'),
     "geometry parameter names must be a list of names, got 'rod1_x'; allowed: rod1_x, rod1_y"),
    (lambda: parameter_vector(CFG, [['rod1_x']]),
     "geometry parameter names must be a list of names, got [['rod1_x']]; allowed: rod1_x"),
    (lambda: config_with_parameters(CFG, [1j], ['rod1_x']), 'the parameter vector must be numbers [SI], got [1j]'),
])
def test_values_that_are_not_numbers_are_refused(call, message):
    """Strings, complex numbers, a 400-digit integer, ragged displacements and names that are not a list of names:
    an InputError naming the argument and the value (numpy's ValueError, TypeError or OverflowError escaped)."""
    with pytest.raises(InputError) as info:
        call()
    assert str(info.value).startswith(message)


@pytest.mark.parametrize('model', MODELS)
def test_rows_of_a_clockwise_machine(model):
    """Rows alternating between the nominal machine and its mirror image (rods and joints at 0, -120, -240 deg,
    clockwise seen from +z): each row is the machine its parameters describe, and the mirror's pose is the mirror
    image (y -> -y) of the nominal machine's for the same rods."""
    mirror = CFG.replace(rod_azimuths=[0.0, -2 * math.pi / 3, -4 * math.pi / 3])
    P = np.array([parameter_vector(CFG), parameter_vector(mirror)] * 4)
    Q = np.repeat(naive_inverse([0.2, 0.35, 0.3, 0.1], [0.03, -0.02, 0.01, 0.034], [0.3, 2.0, -1.0, -2.5]), 2, axis=0)
    fb = forward_batch(Q, CFG, model, parameters=P)
    np.testing.assert_allclose(fb.position[::2], forward_batch(Q[::2], CFG, model).position, rtol=0, atol=5e-16)
    np.testing.assert_allclose(fb.position[1::2], forward_batch(Q[1::2], mirror, model).position, rtol=0, atol=5e-16)
    np.testing.assert_allclose(fb.position[1::2], fb.position[::2] * [1.0, -1.0, 1.0], rtol=0, atol=1e-15)
    assert fb.fit_residual.max() < 1e-13 and fb.residual.max() <= CFG.tolerance


@pytest.mark.parametrize('thin', [0, 1, 2])
def test_a_row_names_the_smallest_angle_of_its_triangle_at_any_corner(thin):
    """Rod positions on the circle of radius R at azimuths that make the corner ``thin`` 4 deg (an inscribed angle is
    half the arc opposite it: 8 deg), the triangle turned by 37 deg: the row is refused with that angle, worked out
    here by the law of cosines."""
    az = np.radians(np.roll([200.0, 0.0, 8.0], thin) + 37.0)
    pts = CFG.radius * np.column_stack([np.cos(az), np.sin(az)])
    a, b, c = (np.linalg.norm(pts[(thin + i) % 3] - pts[(thin + j) % 3]) for i, j in ((1, 2), (0, 1), (0, 2)))
    angle = math.degrees(math.acos((b * b + c * c - a * a) / (2 * b * c)))
    assert angle == pytest.approx(4.0, abs=1e-9)
    P = np.repeat(parameter_vector(CFG)[None], 2, axis=0)
    for k in range(3):
        P[1, PARAMETER_NAMES.index(f'rod{k + 1}_x')], P[1, PARAMETER_NAMES.index(f'rod{k + 1}_y')] = pts[k]
    with pytest.raises(InputError, match=rf'row 1: the triangle of rod_positions has an angle of {angle:.3g} deg'):
        MachineGeometry.per_row(CFG, P)
