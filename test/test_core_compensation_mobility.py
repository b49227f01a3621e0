"""Compensation for offline programming and the mobility/sensitivity analysis (paper §IV-A)."""
import math

import numpy as np
import pytest
from gpr_kinematics.core import forward, inverse, naive_inverse
from gpr_kinematics.core.compensation import compensate
from gpr_kinematics.core.config import MODELS, load_config
from gpr_kinematics.core.mobility import analyze_mobility, exact_dx, rigid_rank, rod_perturbation
from gpr_kinematics.core.rotations import matrix_from_quaternion, quaternion_from_matrix, rotation_z, tilt_rotation
from gpr_kinematics.core.virtual_joints import coordinate_scale, make_model
from gpr_kinematics.errors import InputError, LimitError

CFG = load_config()


@pytest.mark.parametrize('model', MODELS)
def test_compensation_realises_tilt_and_tool_height_and_corrects_the_arm(model):
    rng = np.random.default_rng(3)
    for _ in range(5):
        tilt, az, heading = rng.uniform(0, 1) * CFG.tilt_limit, rng.uniform(-np.pi, np.pi), rng.uniform(-0.3, 0.3)
        R_c = tilt_rotation(tilt, az) @ rotation_z(heading)
        p_c = np.array([0.0, 0.0, rng.uniform(0.1, 0.35)])
        tool = rng.uniform(-0.2, 0.2, 3)
        res = compensate(p_c, quaternion_from_matrix(R_c), tool, model=model)
        fk = forward(res.q, model=model)  # independent check of the commanded rods
        np.testing.assert_allclose(fk.position, res.achieved.position, atol=1e-15)
        assert fk.tilt == pytest.approx(tilt, abs=1e-12)
        tool_real = fk.position + fk.rotation @ tool
        # The height is solved for the platform point the command puts at the commanded place (issue 11,
        # item 8): the tool turned by the commanded heading; without a heading, the tool point itself.
        point = res.platform_point
        np.testing.assert_allclose(point, rotation_z(heading) @ tool, rtol=0, atol=1e-15)
        assert (fk.position + fk.rotation @ point)[2] == pytest.approx((p_c + R_c @ tool)[2], abs=1e-12)
        np.testing.assert_allclose(res.tool_shift, tool_real - (p_c + R_c @ tool), atol=1e-15)
        plain = compensate(p_c, quaternion_from_matrix(tilt_rotation(tilt, az)), tool, model=model)
        plain_real = plain.achieved.position + plain.achieved.rotation @ tool
        assert plain_real[2] == pytest.approx((p_c + tilt_rotation(tilt, az) @ tool)[2], abs=1e-12)
        assert abs(plain.tool_shift[2]) < 1e-12
        # T_a C x = T_c x for any target x in the naive platform frame
        x = rng.uniform(-0.5, 0.5, (10, 3))
        np.testing.assert_allclose(res.correct(x) @ fk.rotation.T + fk.position, x @ R_c.T + p_c, atol=1e-14)
        np.testing.assert_allclose(matrix_from_quaternion(res.arm_correction_quaternion),
                                   res.arm_correction_rotation, atol=1e-14)
        assert res.command_twist == pytest.approx(heading, abs=1e-12)
        # what the arm must do: a rotation about the platform normal, a move in the platform plane, and along
        # the normal only the tilt times the centre shift (which the naive command ignores)
        np.testing.assert_allclose(res.arm_correction_rotation[2], [0.0, 0.0, 1.0], atol=1e-14)
        shift = fk.centre_shift
        assert res.arm_correction_translation[2] == pytest.approx(-fk.normal[:2] @ shift[:2], abs=1e-12)


def test_compensation_of_radial_model_shifts_the_tool_like_the_centre():
    res = compensate([0, 0, 0.5], quaternion_from_matrix(tilt_rotation(math.radians(2.0), 0.0)), model='radial')
    assert res.tool_shift[0] == pytest.approx(28.41e-6, abs=0.01e-6)
    assert res.arm_correction_translation[0] == pytest.approx(-28.41e-6, abs=0.05e-6)


def test_compensation_with_a_heading_solves_the_height_for_the_turned_tool_point():
    """Issue 11, item 8: 0.4 m, 1.5 deg about the axis at 40 deg, tool (0.3, 0, 0.1) m, heading 1 deg. Solving the
    height for the unrotated tool point left the arm a -106 um correction along the platform normal."""
    tilt, az, heading = (math.radians(v) for v in (1.5, 40.0, 1.0))
    R_c = tilt_rotation(tilt, az) @ rotation_z(heading)
    tool = np.array([0.3, 0.0, 0.1])
    res = compensate([0.0, 0.0, 0.4], quaternion_from_matrix(R_c), tool)
    old = inverse(0.4 + (R_c @ tool)[2], tilt, az, tool=tool).achieved  # the old choice of the platform point
    old_normal = (old.rotation.T @ (np.array([0.0, 0.0, 0.4]) - old.position))[2]
    assert old_normal == pytest.approx(-106.085e-6, abs=0.01e-6)
    # now: only the tilt times the centre shift is left along the normal (0.36 um here, <= 1 um at 2 deg)
    normal = res.arm_correction_translation[2]
    assert normal == pytest.approx(-0.362e-6, abs=0.001e-6)
    assert abs(normal) <= math.sin(tilt) * np.linalg.norm(res.achieved.centre_shift[:2]) + 1e-12
    c, s = math.cos(heading), math.sin(heading)
    np.testing.assert_allclose(res.platform_point, [0.3 * c, 0.3 * s, 0.1], rtol=0, atol=1e-16)
    # without a heading and with the tool at the origin nothing changes: the paper's 28.41 um along x
    plain = compensate([0, 0, 0.5], quaternion_from_matrix(tilt_rotation(math.radians(2.0), 0.0)))
    assert plain.tool_shift[0] == pytest.approx(28.41e-6, abs=0.01e-6) and abs(plain.tool_shift[2]) < 1e-15


@pytest.mark.parametrize('position, quat, tool, exc, pattern', [
    ([0, 0, 0.3], [0, 0, 0, 2], [0, 0, 0], InputError, r'has norm 2; a unit quaternion'),
    ([0, 0, float('nan')], [0, 0, 0, 1], [0, 0, 0], InputError, r'position .* NaN or infinity'),
    ([0, 0, 0.3], [0, 0, 0, 1], [0, 0], InputError, r'tool_offset must be 3 numbers'),
    ([0, 0, 0.3], list(quaternion_from_matrix(tilt_rotation(0.05, 0.0))), [0, 0, 0], LimitError,
     r'commanded tilt .* beyond the tilt limit'),
    ([0, 0, 0.9], [0, 0, 0, 1], [0, 0, 0], LimitError, r'outside the stroke'),
    ([0, 0, 0.3], [0, 0, 0, 1], [1e300, 0, 0], LimitError, r'tool_offset = \(1e\+300, 0, 0\) m is beyond the reach'),
    ([0, 0, 0.4], [0, 0, 0, 1], [300, 0, 100], LimitError, r'tool_offset = \(300, 0, 100\) m is beyond the reach'),
    # a command far off the axis came back as an arm correction of 1.7e308 m, success (the ROS service too)
    ([1.7e308, 1.7e308, 0.4], [0, 0, 0, 1], [0, 0, 0], LimitError,
     r'commanded position x, y = \(1.7e\+308, 1.7e\+308\) m, more than 1.7e\+308 m from the GPR axis: the platform '
     r'does not move horizontally .*; allowed: within 10 m of the GPR axis'),
    # the bound is a distance from the axis, as its message says: (9, 9) is 12.7 m away and passed a box of 10 m
    ([9, 9, 0.3], [0, 0, 0, 1], [0, 0, 0], LimitError, r'x, y = \(9, 9\) m, 12.7279 m from the GPR axis'),
    # just beyond: the distance printed apart from the limit ('(10, 0) m ... allowed: within 10 m' read as allowed)
    ([10.0000001, 0, 0.3], [0, 0, 0, 1], [0, 0, 0], LimitError,
     r'x, y = \(10, 0\) m, 10.0000001 m from the GPR axis: .*; allowed: within 10 m of the GPR axis'),
    ([0, 0, 0.3], [0, 0, 0, 1], [10.0000001, 0, 0], LimitError,
     r'tool_offset = \(10, 0, 0\) m is beyond the reach of a tool point \(10.0000001 m from the platform origin\); '
     r'allowed: at most 10 m'),
])
def test_compensation_rejects_bad_commands(position, quat, tool, exc, pattern):
    with pytest.raises(exc, match=pattern):
        compensate(position, quat, tool)


def test_a_command_off_the_axis_leaves_the_arm_its_part_along_the_normal():
    """docs/core.md: at x = y = 0 the correction's part along the normal is the tilt times the centre shift (< 1 um
    at 2 deg); a command x = 10 mm off the axis adds n . (x, 0, 0) = sin(2 deg) 10 mm, 349 um, which no planar arm
    makes."""
    half = math.radians(2.0) / 2
    quat = [0.0, math.sin(half), 0.0, math.cos(half)]  # 2 deg about y: the normal leans towards +x
    at_axis = compensate([0.0, 0.0, 0.4], quat).arm_correction.translation
    off = compensate([0.01, 0.0, 0.4], quat).arm_correction.translation
    assert abs(at_axis[2]) < 1e-6
    assert off[2] - at_axis[2] == pytest.approx(0.01 * math.sin(math.radians(2.0)), abs=1e-15)


@pytest.mark.parametrize('model', MODELS)
def test_ranks_9_at_singularity_11_elsewhere_12_augmented(model):
    rng = np.random.default_rng(9)
    for z in (0.05, 0.25, 0.5):
        m = analyze_mobility([z, z, z], model=model)
        assert (m.rank_dphi_dp, m.rank_augmented, m.mobility) == (9, 12, 3)
    for _ in range(6):
        q = naive_inverse(rng.uniform(0.1, 0.4), rng.uniform(1e-5, 1) * CFG.tilt_limit, rng.uniform(-3, 3))
        m = analyze_mobility(q, model=model)
        assert (m.rank_dphi_dp, m.rank_augmented, m.mobility) == (11, 12, 1)


@pytest.mark.parametrize('model', MODELS)
def test_mobility_equals_the_separate_decompositions(model):
    """analyze_mobility takes the pseudo-inverse of the non-zero rows of dPhi/dX, the eigenvalues from the SVD of
    dX/dP and both ranks from one batched SVD: the same numbers as the textbook route on the whole matrices."""
    rng = np.random.default_rng(31)
    rods = [[0.5, 0.5, 0.5], [0.05, 0.05, 0.05]] + [naive_inverse(rng.uniform(0.06, 0.44), rng.uniform(0, 1)
                                                                  * CFG.tilt_limit, rng.uniform(-3, 3))
                                                    for _ in range(8)]
    for q in rods:
        m = analyze_mobility(q, CFG, model)
        s = coordinate_scale(make_model(CFG, model), CFG)
        dx_dp = -(np.linalg.pinv(m.dphi_dx / s) / s[:, None]) @ m.dphi_dp
        np.testing.assert_allclose(m.dx_dp, dx_dp, rtol=0, atol=1e-12 * np.abs(dx_dp).max())
        evals, evecs = np.linalg.eigh(dx_dp.T @ dx_dp)
        np.testing.assert_allclose(m.eigenvalues, evals, rtol=0, atol=1e-12 * evals[-1])
        top, mine = evecs[:, -3:], m.eigenvectors[:, -3:]   # the same subspace (the vectors up to sign)
        np.testing.assert_allclose(top @ top.T, mine @ mine.T, atol=1e-10)
        np.testing.assert_allclose(m.eigenvectors.T @ m.eigenvectors, np.eye(12), atol=1e-14)
        sv = np.linalg.svd(dx_dp, compute_uv=False)
        np.testing.assert_allclose(m.singular_values, sv[:m.singular_values.size], rtol=1e-12)
        assert m.rank_dphi_dp == np.linalg.matrix_rank(m.dphi_dp) == 12 - m.mobility
        assert m.rank_augmented == np.linalg.matrix_rank(np.hstack([m.dphi_dp, m.dphi_dx])) == 12


@pytest.mark.parametrize('columns', [3, 6])
def test_pseudo_inverse_of_the_closure_rows_is_numpys(columns):
    """The closure's rows (3 x M, full row rank) are inverted by the normal equations in floats where they are well
    conditioned: numpy's pinv to 1e-12 at the threshold's worst conditions; beyond it, and where the rank is lost,
    the SVD route itself (the same bits)."""
    from gpr_kinematics.core.mobility import PINV_NORMAL_CONDITION, _pinv, _pinv_rows
    rng = np.random.default_rng(5)
    # trace(G)^3 / det(G) of G's eigenvalues s^2: 812, 7338, 76 and 6406 (cond(G) 800) within; 10612, 8e6, inf not
    cases = {(1.0, 1.0, 0.1): True, (1.0, 0.11, 0.11): True, (3.0, 2.0, 1.0): True, (1.0, 1.0, 0.0354): True,
             (1.0, 0.1, 0.1): False, (1.0, 1.0, 1e-3): False, (1.0, 1.0, 0.0): False}
    for singular, within in cases.items():
        for _ in range(20):
            u = np.linalg.qr(rng.normal(size=(3, 3)))[0]
            v = np.linalg.qr(rng.normal(size=(columns, columns)))[0][:3]
            A = (u * singular) @ v * rng.uniform(0.01, 100.0)
            G = A @ A.T
            normal = np.linalg.det(G) * PINV_NORMAL_CONDITION >= np.trace(G) ** 3
            assert normal == within
            ref = np.linalg.pinv(A)
            got = _pinv_rows(A)
            if normal:
                np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max())
            else:
                assert got.tobytes() == _pinv(A).tobytes()
                np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9 * np.abs(ref).max())


@pytest.mark.parametrize('model', MODELS)
def test_sensitivity_satisfies_linearised_constraints_and_bounds(model):
    m = analyze_mobility(naive_inverse(0.3, math.radians(1.3), 0.4), model=model)
    rng = np.random.default_rng(10)
    # dPhi/dP dP + dPhi/dX dX = 0 (eq. 3) for dP on the rod kinematics
    for _ in range(5):
        dP = rod_perturbation(rng.normal(scale=1e-4, size=3))
        dX = m.dx_dp @ dP
        assert np.linalg.norm(m.dphi_dp[9:] @ dP + m.dphi_dx[9:] @ dX) < 1e-12 * np.linalg.norm(m.dphi_dp @ dP)
        b = m.dx_bounds(dP)
        assert b.lower_eq4 * (1 - 1e-9) <= b.norm_dx <= b.upper_eq4 * (1 + 1e-9)
        assert b.lower_eq5 * (1 - 1e-9) <= b.norm_dx <= b.upper_eq5 * (1 + 1e-9)
        assert b.lower_eq4 == pytest.approx(b.lower_eq5, rel=1e-9)  # eigenvalues of A^T A are sigma^2
    assert np.count_nonzero(m.eigenvalues > 1e-12 * m.eigenvalues[-1]) == 3
    assert m.singular_values.size == 3
    with pytest.raises(InputError, match='12 finite numbers'):
        m.dx_bounds(np.zeros(5))


def test_radial_sensitivity_is_the_derivative_of_forward_kinematics():
    """For the square radial model X(q) is unique, so dX/dP dP(dq) equals finite differences of FK."""
    q = naive_inverse(0.3, math.radians(1.5), 1.1)
    m = analyze_mobility(q, model='radial')
    h = 1e-7
    for k in range(3):
        dq = np.zeros(3)
        dq[k] = h
        fd = (forward(q + dq, model='radial').virtual_joints - forward(q - dq, model='radial').virtual_joints) / (2 * h)
        np.testing.assert_allclose(m.dx_dp @ rod_perturbation(dq) / h, fd, rtol=1e-6, atol=1e-9)


def test_changes_must_stay_within_the_stroke_and_the_first_order_is_named_as_such():
    m = analyze_mobility([0.5, 0.5, 0.5])
    assert m.singular and m.stroke == (0.0, 0.508)
    with pytest.raises(LimitError, match=r'q1 \+ dq1 = 1e\+308 m is outside the stroke'):
        m.dx_bounds(m.rod_perturbation([1e308, 0, 0]))   # was |dX| = 0 and bounds inf, exit 0
    big = np.zeros(12)
    big[5] = 1e308   # a joint centre moved by itself (dP given whole): the size bound, nothing overflows
    with pytest.raises(InputError, match=r'a change larger than the stroke range 0\.508 m'):
        m.dx_bounds(big)
    with pytest.raises(LimitError, match=r'q1 \+ dq1 = 0\.51 m is outside the stroke \[0, 0\.508\] m'):
        m.dx_bounds(m.rod_perturbation([0.01, 0, 0]))
    # At the singular configuration the first order vanishes; the full solve does not: second order in dq.
    dq = np.array([1e-4, -1e-4, 0.0])
    assert m.dx_bounds(m.rod_perturbation(dq)).norm_dx == 0.0
    full = [np.linalg.norm(exact_dx([0.5] * 3, s * dq)) for s in (1.0, 0.5)]
    assert full[0] == pytest.approx(0.1073e-6, abs=0.0001e-6) and full[0] / full[1] == pytest.approx(4.0, rel=1e-3)
    # Off the singular configuration the full solve agrees with the first order to second order.
    q = naive_inverse(0.3, math.radians(1.0), 0.4)
    m = analyze_mobility(q)
    assert not m.singular and m.mobility == 1
    np.testing.assert_allclose(exact_dx(q, 1e-6 * dq), m.dx_dp @ rod_perturbation(1e-6 * dq), rtol=1e-4)


def test_the_float_rank_test_is_the_array_one():
    """``rank_of`` (one matrix, floats; the one-pose mobility) and ``numerical_rank`` (arrays; ``rigid_rank``) take
    the same decision for every singular value, those at the threshold (``matrix_rank``'s) and one ulp off included."""
    from gpr_kinematics.core.mobility import EPS, numerical_rank, rank_of
    rng = np.random.default_rng(7)
    for columns in (12, 15, 18):
        for _ in range(200):
            S = np.sort(rng.choice([0.0, 1e-300, 1.0, 2.5], 12) * rng.uniform(0.5, 2.0, 12))[::-1].copy()
            t = S[0] * (max(12, columns) * EPS)
            k = rng.integers(1, 12)
            S[k:] = np.sort(rng.choice([t, np.nextafter(t, 0.0), np.nextafter(t, 1.0), 0.0], 12 - k))[::-1]
            assert rank_of(S.tolist(), columns) == int(numerical_rank(S, columns))


def test_rigid_rank_is_the_rank_of_the_constraint_jacobian():
    q = np.array([[0.5, 0.5, 0.5], [0.2, 0.2, 0.2], [0.5, 0.501, 0.5]])
    assert rigid_rank(q).tolist() == [9, 9, 11]
    assert [analyze_mobility(row).rank_dphi_dp for row in q] == [9, 9, 11]


def test_one_pose_constraint_jacobian_is_the_batch_one_and_results_are_their_own():
    """``dPhi/dP`` of one pose (the pose-independent rows kept per config, the edges written in) equals
    :func:`constraint_jacobian`, on rods that are not parallel too; a result's arrays are its own."""
    from gpr_kinematics.core.machine import MachineGeometry, config_with_parameters
    from gpr_kinematics.core.mobility import constraint_jacobian
    bent = config_with_parameters(load_config(), [1e-4, -2e-4, 3e-5], ['rod1_ux', 'rod2_uy', 'rod2_offset'])
    for cfg in (load_config(), bent):
        geo = MachineGeometry.of(cfg)
        u = np.array([geo.ux, geo.uy, geo.uz]).T
        for q in ([0.3, 0.3, 0.3], [0.3, 0.302, 0.299]):
            first = analyze_mobility(q, cfg)
            np.testing.assert_array_equal(first.dphi_dp, constraint_jacobian(geo.base_points(np.array([q])), u)[0])
            np.testing.assert_array_equal(first.rod_directions, u)
            first.dphi_dp[:] = 0.0
            first.rod_directions[:] = 0.0  # the next analysis is not touched
            again = analyze_mobility(q, cfg)
            np.testing.assert_array_equal(again.dphi_dp, constraint_jacobian(geo.base_points(np.array([q])), u)[0])
            np.testing.assert_array_equal(again.rod_directions, u)
        assert analyze_mobility([0.3, 0.3, 0.3], cfg).rank_dphi_dp == (9 if cfg is not bent else 12)


@pytest.mark.parametrize('call, words', [
    (lambda: rigid_rank([np.nan, 0.25, 0.25]), r'q1 = nan is not a finite number'),   # LAPACK raised
    (lambda: rigid_rank([np.inf, 0.25, 0.25]), r'q1 = inf is not a finite number'),   # was rank 0
    (lambda: rigid_rank([0.25] * 4), r'q must have 3 values per sample'),             # was rank 9
    (lambda: rigid_rank([]), r'q must have 3 values per sample'),
    (lambda: exact_dx([0.25] * 3, [0, 0, 0, 0]), r'dq must be 3 numbers, got shape \(4,\)'),
    (lambda: exact_dx([0.25] * 3, 'abc'), r'dq must be 3 numbers'),
    (lambda: rod_perturbation([1e-4, 0, 0], np.full((3, 3), np.nan)), r'directions = .*; allowed: finite values'),
    (lambda: naive_inverse(np.nan, 0.0, 0.0), r'height = nan; allowed: finite values'),     # was NaN rods
    (lambda: naive_inverse(0.3, 1j, 0.0), r'tilt must be numbers'),
    (lambda: naive_inverse([0.1, 0.2], [0.0, 0.0, 0.0], 0.0), r'must broadcast together'),
])
def test_mobility_helpers_and_the_naive_model_name_bad_input(call, words):
    with pytest.raises(InputError, match=words):
        call()


def test_naive_pose_refuses_what_would_be_a_rotation_of_nan():
    from gpr_kinematics.core.naive import naive_pose

    with pytest.raises(InputError, match=r'tilt = inf; allowed: finite values'):
        naive_pose(0.2, np.inf, 0.0)
    pos, R = naive_pose([0.2, 0.3], 0.01, 0.5)
    np.testing.assert_allclose(pos[:, 2], [0.2, 0.3])
    np.testing.assert_allclose(R[0], tilt_rotation(0.01, 0.5))


@pytest.mark.parametrize('model', MODELS)
def test_reported_gains_are_the_extreme_singular_values_of_dx_dp(model):
    """The gains of eqs. (4) and (5) reported with the analysis: ``sqrt(d10), sqrt(d12)`` of the eigenvalues of
    ``dX/dP^T dX/dP`` and the smallest and largest non-zero singular values of ``dX/dP`` (numpy's SVD and eigh of
    the reported ``dx_dp`` here), the same pair twice; ``dx_bounds`` scales them by the projected ``|dP|``."""
    m = analyze_mobility(naive_inverse(0.3, math.radians(1.3), 0.4), model=model)
    sv = np.linalg.svd(m.dx_dp, compute_uv=False)[:3]
    assert sv[2] < 0.9 * sv[1]   # three distinct gains: the smallest is not the middle one
    d = np.linalg.eigvalsh(m.dx_dp.T @ m.dx_dp)
    np.testing.assert_allclose(m.bounds['eq5'], (sv[2], sv[0]), rtol=1e-12)
    np.testing.assert_allclose(m.bounds['eq4'], (math.sqrt(d[9]), math.sqrt(d[11])), rtol=1e-9)
    dP = m.rod_perturbation([1e-4, -2e-4, 0.5e-4])
    proj = np.linalg.norm(m.eigenvectors[:, -3:].T @ dP)
    b = m.dx_bounds(dP)
    np.testing.assert_allclose(b.eq5, np.array(m.bounds['eq5']) * proj, rtol=1e-12)
    np.testing.assert_allclose(b.eq4, np.array(m.bounds['eq4']) * proj, rtol=1e-9)


def test_compensation_without_a_tool_is_that_of_the_platform_origin():
    """The default tool point is the platform origin: no tool argument gives what (0, 0, 0) gives (a command with a
    heading, which the GPR cannot follow, so that a tool point off the origin would shift by the heading)."""
    quaternion = quaternion_from_matrix(tilt_rotation(0.02, 0.7) @ rotation_z(0.3))
    position = np.array([0.01, -0.02, 0.3])
    a, b = compensate(position, quaternion), compensate(position, quaternion, (0.0, 0.0, 0.0))
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.tool_shift, b.tool_shift)
    np.testing.assert_array_equal(a.arm_correction_translation, b.arm_correction_translation)


def test_a_rod_change_that_is_no_number_is_named_as_the_stroke_refusal_names_it():
    """``dq[0] = inf`` beside ``q1 + dq1 = ... outside the stroke``: one element, named two ways (0- and 1-based)."""
    from gpr_kinematics.core.mobility import analyze_mobility, rod_change
    from gpr_kinematics.errors import InputError, LimitError
    res = analyze_mobility([0.5, 0.5, 0.5])
    with pytest.raises(InputError, match=r'dq = \[inf, 0\.0, 0\.0\] contains NaN or infinity: dq1 = inf is not a '
                                         r'finite number'):
        rod_change(res, [math.inf, 0.0, 0.0])
    with pytest.raises(LimitError, match=r'^q1 \+ dq1 = '):
        rod_change(res, [1.0, 0.0, 0.0])
