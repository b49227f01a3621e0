"""Imperfect geometry: per-rod base points, zero offsets and directions, per-joint platform positions; the
validation of every value, the kinematics on an imperfect machine, the naive model, mobility, the parameter
vector."""
import dataclasses
import math

import numpy as np
import pytest
from gpr_kinematics.core import forward, forward_batch, inverse, inverse_batch, naive_forward, naive_inverse
from gpr_kinematics.core.config import MODELS, GprConfig, load_config
from gpr_kinematics.core.machine import config_with_parameters, parameter_vector
from gpr_kinematics.core.mobility import analyze_mobility
from gpr_kinematics.core.parameters import PARAMETER_KEYS, PARAMETER_NAMES, PARAMETERS
from gpr_kinematics.core.sweep import paper_sweep
from gpr_kinematics.core.virtual_joints import make_model
from gpr_kinematics.errors import ConfigError, InputError

CFG = load_config()
R = CFG.radius
TH = np.asarray(CFG.rod_azimuths)
NOMINAL = np.stack([R * np.cos(TH), R * np.sin(TH)], -1)
#: A machine as a calibration might find it: tens of micrometres, rods tilted by about 0.1 mrad.
REAL = dict(rod_positions=(NOMINAL + [[2e-5, -1e-5], [-3e-5, 1.5e-5], [1e-5, 2.5e-5]]).tolist(),
            rod_offsets=[3e-5, -2e-5, 1e-5], rod_directions=[[1e-4, -5e-5], [-8e-5, 1e-4], [5e-5, 6e-5]],
            platform_joints=(NOMINAL + [[-1e-5, 2e-5], [2e-5, 1e-5], [-1.5e-5, -2e-5]]).tolist(), kappa=[5.0, 2.0, 8.0])


def real(model='radial', **changes):
    return CFG.replace(model=model, **REAL, **changes)


def joint_centres(cfg, q):
    """P_k = B_k + (q_k + o_k) u_k, written here from the config's values."""
    B = np.column_stack([np.asarray(cfg.rod_positions), np.zeros(3)])
    d = np.asarray(cfg.rod_directions)
    u = np.column_stack([d, np.sqrt(1 - np.sum(d * d, axis=1))])
    return B + (np.asarray(q) + np.asarray(cfg.rod_offsets))[:, None] * u


def test_cross_checks_of_the_triangles():
    with pytest.raises(ConfigError, match=r'rod_positions = .* has an angle of .* deg; allowed: every angle >= 5'):
        CFG.replace(rod_positions=[[0.1, 0.0], [0.0, 0.0], [-0.1, 0.001]])
    with pytest.raises(ConfigError, match='same order around the triangle'):
        CFG.replace(platform_joints=NOMINAL[::-1].tolist(), rod_positions=NOMINAL.tolist())
    with pytest.raises(ConfigError, match=r'side 1-2 of the joint triangle is .* allowed: within 1% of each other'):
        CFG.replace(platform_joints=(NOMINAL + [[0.01, 0.0], [0.0, 0.0], [0.0, 0.0]]).tolist())


def test_nominal_values_given_explicitly_change_nothing():
    explicit = CFG.replace(rod_positions=NOMINAL.tolist(), platform_joints=NOMINAL.tolist())
    Q = naive_inverse(np.full(20, 0.3), np.linspace(-0.03, 0.03, 20), np.linspace(-3, 3, 20))
    for model in MODELS:
        a, b = forward_batch(Q, model=model), forward_batch(Q, config=explicit, model=model)
        np.testing.assert_allclose(b.position, a.position, rtol=0, atol=1e-15)
        np.testing.assert_allclose(b.virtual_joints, a.virtual_joints, rtol=0, atol=1e-15)


@pytest.mark.parametrize('model', MODELS)
def test_forward_on_an_imperfect_machine_puts_the_joints_on_the_rods(model):
    cfg = real(model)
    rng = np.random.default_rng(4)
    Q = naive_inverse(rng.uniform(0.1, 0.4, 30), rng.uniform(-1, 1, 30) * CFG.tilt_limit, rng.uniform(-3, 3, 30), cfg)
    fb = forward_batch(Q, config=cfg)
    r2, _, _ = make_model(cfg, model).points_and_partials(fb.virtual_joints)
    r = np.concatenate([r2, np.zeros(r2.shape[:-1] + (1,))], axis=-1)
    for i in range(30):
        P = joint_centres(cfg, Q[i])
        np.testing.assert_allclose(r[i] @ fb.rotation[i].T + fb.position[i], P, rtol=0, atol=1e-12)
        n = np.cross(P[1] - P[0], P[2] - P[0])
        np.testing.assert_allclose(fb.normal[i], n / np.linalg.norm(n), atol=1e-14)
        np.testing.assert_allclose(fb.side_lengths[i], np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1),
                                   rtol=0, atol=1e-15)
        # the joints move from their own places p_k on the platform
        np.testing.assert_allclose(fb.joint_displacement[i],
                                   np.linalg.norm(r2[i] - np.asarray(cfg.platform_joints), axis=1), atol=1e-15)


@pytest.mark.parametrize('model', MODELS)
def test_inverse_round_trip_on_an_imperfect_machine(model):
    cfg = real(model)
    rng = np.random.default_rng(5)
    h, t, g = rng.uniform(0.1, 0.4, 100), rng.uniform(-1, 1, 100) * CFG.tilt_limit, rng.uniform(-3, 3, 100)
    ib = inverse_batch(h, t, g, config=cfg)
    fb = forward_batch(ib.q, config=cfg)
    assert np.max(np.abs(fb.position[:, 2] - h)) < 1e-12
    assert np.max(np.abs(fb.tilt - np.abs(t))) < 1e-12
    one = inverse(h[7], t[7], g[7], config=cfg)
    np.testing.assert_allclose(one.q, ib.q[7], rtol=0, atol=1e-14)


def test_the_naive_model_of_an_imperfect_machine():
    """(q_k + o_k) u_kz = z + n' . p_k: the joint heights are right, horizontal effects ignored (docs/core.md)."""
    cfg = real()
    q = naive_inverse(0.35, 0.02, 0.7, cfg)
    pos, rot = naive_forward(q, cfg)
    n_prime = rot[0].T @ [0.0, 0.0, 1.0]
    p = np.column_stack([np.asarray(cfg.platform_joints), np.zeros(3)])
    uz = np.sqrt(1 - np.sum(np.asarray(cfg.rod_directions) ** 2, axis=1))
    np.testing.assert_allclose((q + cfg.rod_offsets) * uz, 0.35 + p @ n_prime, rtol=0, atol=1e-15)
    assert pos[0, 2] == pytest.approx(0.35, abs=1e-15) and pos[0, 0] == pos[0, 1] == 0.0


def test_an_offset_is_a_rod_length_and_a_base_shift_moves_the_platform():
    """Independent checks of B_k and o_k: an offset o adds to q; moving every base point by d moves the pose by d."""
    q = np.array([0.3, 0.302, 0.299])
    o = np.array([2e-4, -1e-4, 3e-4])
    a, b = forward(q, config=CFG.replace(rod_offsets=o.tolist())), forward(q + o)
    for name in ('position', 'rotation', 'virtual_joints', 'centre_shift'):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=0, atol=1e-16, err_msg=name)
    d = np.array([3e-4, -2e-4])
    moved = forward(q, config=CFG.replace(rod_positions=(NOMINAL + d).tolist()))
    np.testing.assert_allclose(moved.position - forward(q).position, [d[0], d[1], 0.0], rtol=0, atol=1e-16)
    np.testing.assert_allclose(moved.rotation, forward(q).rotation, atol=1e-16)


def test_the_sweep_on_an_imperfect_machine():
    s = paper_sweep(azimuth_step=math.radians(45.0), config=real('compliant'))
    assert np.max(np.abs(s.forward.position[:, 2] - 0.5)) < 1e-12
    assert np.max(np.abs(s.forward.tilt - np.abs(s.alpha))) < 1e-12
    assert s.forward.iterations.max() <= 4


def test_mobility_ranks_for_parallel_and_for_non_parallel_rods():
    q_equal, q_tilted = [0.3, 0.3, 0.3], naive_inverse(0.3, 0.02, 1.0)
    u = np.array([0.01, -0.02, math.sqrt(1 - 0.01 ** 2 - 0.02 ** 2)])
    alike = CFG.replace(rod_directions=[u[:2].tolist()] * 3)  # parallel, but not vertical
    # singular where the joint triangle is perpendicular to the rods: (P_b - P_a) . u = (B_b - B_a) . u + q_b - q_a = 0
    q_perpendicular = 0.3 - NOMINAL @ u[:2]
    for model in MODELS:
        assert analyze_mobility(q_perpendicular, config=alike, model=model).rank_dphi_dp == 9
        assert analyze_mobility(q_equal, config=alike, model=model).rank_dphi_dp == 11
        assert analyze_mobility(q_tilted, config=alike, model=model).rank_dphi_dp == 11
    apart = CFG.replace(rod_directions=REAL['rod_directions'])  # not parallel: the rigid platform cannot move
    for q in (q_equal, q_tilted):
        m = analyze_mobility(q, config=apart)
        assert (m.rank_dphi_dp, m.mobility, m.rank_augmented) == (12, 0, 12)
    # equal extensions of non-parallel rods change a side length (the reason), parallel ones do not
    dP = m.rod_perturbation([1e-3, 1e-3, 1e-3])
    assert np.linalg.norm(m.dphi_dp[9:] @ dP) > 1e-9
    par = analyze_mobility(q_tilted)
    assert np.linalg.norm(par.dphi_dp[9:] @ par.rod_perturbation([1e-3, 1e-3, 1e-3])) < 1e-18


def test_non_parallel_rods_lose_one_rank_where_the_rods_length_changes_keep_the_sides():
    """Non-parallel rods are rank 12 at almost every configuration, not everywhere (a docs claim): with
    ``dP_k = u_k dq_k`` the side lengths' rows ``2 e_ab . (u_b dq_b - u_a dq_a)`` form a 3 x 3 matrix ``M`` whose
    determinant changes sign with the rods' lengths; where it is 0 (found here by bisection on q3, with base points
    and directions taken from the configuration) ``dq = ker M`` keeps all three sides: rank 11, h = 1, still not
    singular (h > 1)."""
    ux, uy = np.array([[0.001, 0.0], [-0.001, 0.0], [0.0, 0.0]]).T
    cfg = CFG.replace(rod_directions=np.column_stack([ux, uy]).tolist())
    B = np.column_stack([NOMINAL, np.zeros(3)])   # rod_positions unset: the nominal radius and azimuths
    u = np.column_stack([ux, uy, np.sqrt(1.0 - ux ** 2 - uy ** 2)])

    def m_matrix(q3):
        P = B + np.array([0.25, 0.248, q3])[:, None] * u
        M = np.zeros((3, 3))
        for row, (a, b) in enumerate(((0, 1), (1, 2), (2, 0))):
            e = P[b] - P[a]
            M[row, a], M[row, b] = -e @ u[a], e @ u[b]
        return M

    lo, hi = 0.2475, 0.2485
    assert np.linalg.det(m_matrix(lo)) * np.linalg.det(m_matrix(hi)) < 0.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if np.linalg.det(m_matrix(lo)) * np.linalg.det(m_matrix(mid)) > 0.0 else (lo, mid)
    m = analyze_mobility([0.25, 0.248, lo], config=cfg)
    assert (m.rank_dphi_dp, m.mobility, m.rank_augmented, m.singular) == (11, 1, 12, False)
    dq = np.linalg.svd(m_matrix(lo))[2][-1]
    assert np.linalg.norm(m.dphi_dp @ m.rod_perturbation(1e-3 * dq)) < 1e-15   # the lost rank's motion
    for q3 in (lo - 1e-6, lo + 1e-6):   # on either side: rank 12
        assert analyze_mobility([0.25, 0.248, q3], config=cfg).rank_dphi_dp == 12


def test_parameter_vector_round_trip_and_errors():
    cfg = real('compliant')
    v = parameter_vector(cfg)
    assert v.shape == (24,) and len(PARAMETER_NAMES) == 24 and {p.unit for p in PARAMETERS} == {'m', 'rad', '1'}
    assert config_with_parameters(GprConfig(), v) == GprConfig().replace(**REAL)
    back = config_with_parameters(CFG, v)
    np.testing.assert_array_equal(parameter_vector(back), v)
    Q = naive_inverse(np.full(5, 0.3), np.linspace(-0.03, 0.03, 5), 0.4, cfg)
    np.testing.assert_array_equal(forward_batch(Q, config=back, model='compliant').position,
                                  forward_batch(Q, config=cfg).position)
    nominal = parameter_vector(GprConfig())
    assert nominal[PARAMETER_NAMES.index('rod2_y')] == pytest.approx(R * math.sin(TH[1]), abs=1e-18)
    with pytest.raises(InputError, match='unknown geometry parameter'):
        parameter_vector(cfg, ['rod4_x'])
    with pytest.raises(InputError, match='a parameter vector of 2 values'):
        config_with_parameters(cfg, [1.0], ['rod1_x', 'rod1_y'])
    with pytest.raises(ConfigError, match=r'rod_offsets = .* is invalid; allowed: .* -0.1 <= o_k <= 0.1'):
        config_with_parameters(cfg, [0.5], ['rod1_offset'])


#: A change of every key of a geometry file: the parameters move with the keys of PARAMETER_KEYS and no others.
CHANGED = {'radius': 0.1, 'rod_azimuths': (0.01, 2.1, 4.2), 'stroke_min': 0.01, 'stroke_max': 0.5,
           'tilt_limit': 0.03, 'imperfection_budget': 1e-3, 'model': 'compliant', 'characteristic_length': 0.1,
           'weighting': 'unweighted', 'max_iterations': 20, 'tolerance': 1e-13,
           'rod_positions': ((0.0935, 0.0), (-0.0466, 0.0807), (-0.0466, -0.0807)), 'rod_offsets': (1e-3, 0.0, 0.0),
           'rod_directions': ((1e-3, 0.0), (0.0, 0.0), (0.0, 0.0)),
           'platform_joints': ((0.0935, 0.0), (-0.0466, 0.0807), (-0.0466, -0.0807)), 'kappa': (500.0, 1e3, 1e3)}


def test_the_keys_the_parameters_are_made_of():
    """PARAMETER_KEYS (a robot's gpr section setting one leaves its file's covariance out) are exactly the keys whose
    change moves the parameter vector; every key of the config is tried, so a new one must be placed."""
    assert set(CHANGED) == {f.name for f in dataclasses.fields(GprConfig)}
    base = parameter_vector(GprConfig())
    moved = {k for k, v in CHANGED.items() if not np.array_equal(parameter_vector(GprConfig().replace(**{k: v})), base)}
    assert moved == PARAMETER_KEYS


@pytest.mark.parametrize('model', MODELS)
def test_an_irregular_layout_and_its_mirror_image(model):
    """Rods at 0, 60 and 170 deg (counter-clockwise, an irregular triangle) and the mirror image at 0, -60, -170 deg
    (clockwise): in both the joints sit on the rods (``P_k = Rot r_k + t``), the platform is level at equal rods, and
    the mirror machine's pose is the mirror (y -> -y) of the first's for the same rods."""
    th = np.radians([0.0, 60.0, 170.0])
    cfg = CFG.replace(model=model, rod_azimuths=th.tolist())
    mirror = CFG.replace(model=model, rod_azimuths=(-th).tolist())
    rng = np.random.default_rng(6)
    Q = np.vstack([[0.3, 0.3, 0.3], naive_inverse(rng.uniform(0.1, 0.4, 20), rng.uniform(-0.9, 0.9, 20)
                                                  * CFG.tilt_limit, rng.uniform(-3, 3, 20), cfg)])
    M = np.diag([1.0, -1.0, 1.0])
    fa, fb = forward_batch(Q, config=cfg), forward_batch(Q, config=mirror)
    for f, c in ((fa, cfg), (fb, mirror)):
        r2, _, _ = make_model(c, model).points_and_partials(f.virtual_joints)
        r = np.concatenate([r2, np.zeros(r2.shape[:-1] + (1,))], axis=-1)
        B = np.column_stack([R * np.cos(c.rod_azimuths), R * np.sin(c.rod_azimuths), np.zeros(3)])
        for i in range(Q.shape[0]):
            P = B + Q[i][:, None] * [0.0, 0.0, 1.0]
            np.testing.assert_allclose(r[i] @ f.rotation[i].T + f.position[i], P, rtol=0, atol=1e-12)
        np.testing.assert_allclose(f.rotation[0], np.eye(3), rtol=0, atol=1e-15)
        np.testing.assert_allclose(f.position[0], [0.0, 0.0, 0.3], rtol=0, atol=1e-15)
    np.testing.assert_allclose(fb.position, fa.position @ M, rtol=0, atol=1e-13)
    np.testing.assert_allclose(fb.rotation, M @ fa.rotation @ M, rtol=0, atol=1e-13)


@pytest.mark.parametrize('model', MODELS)
def test_a_layout_turned_about_z_turns_the_pose(model):
    """Every rod and joint turned by 50 deg about the base z axis (rod 1 no longer on the x axis): the same rods give
    the same pose turned by 50 deg, ``t' = Rz t`` and ``Rot' = Rz Rot Rz^T``, and the same side lengths and joint
    displacements (the virtual joints are in each joint's own radial and tangential directions)."""
    turn = math.radians(50.0)
    cfg = CFG.replace(model=model)
    turned = CFG.replace(model=model, rod_azimuths=(TH + turn).tolist())
    rng = np.random.default_rng(7)
    Q = naive_inverse(rng.uniform(0.1, 0.4, 20), rng.uniform(-0.9, 0.9, 20) * CFG.tilt_limit, rng.uniform(-3, 3, 20))
    fa, fb = forward_batch(Q, config=cfg), forward_batch(Q, config=turned)
    Rz = np.array([[math.cos(turn), -math.sin(turn), 0.0], [math.sin(turn), math.cos(turn), 0.0], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(fb.position, fa.position @ Rz.T, rtol=0, atol=1e-15)
    np.testing.assert_allclose(fb.rotation, Rz @ fa.rotation @ Rz.T, rtol=0, atol=1e-14)
    np.testing.assert_allclose(fb.virtual_joints, fa.virtual_joints, rtol=0, atol=1e-14)
    np.testing.assert_allclose(fb.joint_displacement, fa.joint_displacement, rtol=0, atol=1e-15)
    for k in range(0, 20, 5):   # the one-pose path too
        np.testing.assert_allclose(forward(Q[k], config=turned).position, fb.position[k], rtol=0, atol=1e-15)
