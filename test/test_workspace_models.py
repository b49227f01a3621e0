"""Workspace models: point constraints against independent kinematics, interval enclosures against
sampling, and the papers' formulas (Posypkin et al.; Aboulissane and El Bakkali; docs/references.md)."""
import math

import numpy as np
import pytest
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.workspace.dextar import DextarModel
from gpr_kinematics.workspace.gpr import GprModel
from gpr_kinematics.workspace.interval import Interval
from gpr_kinematics.workspace.loader import load_workspace_model, model_from_mapping
from gpr_kinematics.workspace.planar import Rrr3PlanarModel
from gpr_kinematics.workspace.shell_arm import ShellArmModel
from gpr_kinematics.workspace.tripod import TripodModel
from gpr_kinematics.workspace.upu3 import Upu3Model

RNG = np.random.default_rng(7)
FILES = ['tripod_3rps', 'upu3', 'gpr', 'rrr3_planar', 'dextar', 'shell_arm']


def _uniform(box, n):
    return box[:, 0] + (box[:, 1] - box[:, 0]) * RNG.random((n, box.shape[0]))


@pytest.mark.parametrize('name', FILES)
def test_enclosures_contain_point_values_on_small_and_large_boxes(name):
    model = load_workspace_model(config_path(f'mechanisms/{name}.yaml'))
    d = len(model.variables)
    for rel in (0.3, 0.02, 0.001):
        centres = _uniform(model.box, 300)
        half = rel * (model.box[:, 1] - model.box[:, 0]) * RNG.random((300, d))
        boxes = np.stack([np.maximum(centres - half, model.box[:, 0]),
                          np.minimum(centres + half, model.box[:, 1])], axis=2)
        lo, hi = model.bounds(boxes)
        t = RNG.random((40, 300, d))
        pts = boxes[None, :, :, 0] + (boxes[None, :, :, 1] - boxes[None, :, :, 0]) * t
        pts = np.clip(pts, boxes[None, :, :, 0], boxes[None, :, :, 1])
        g = model.evaluate(pts.reshape(-1, d)).reshape(40, 300, -1)
        defined = np.isfinite(g)
        assert np.all((lo[None] <= g) | ~defined)
        assert np.all((g <= hi[None]) | ~defined)
        if rel == 0.001 and name != 'rrr3_planar':
            # enclosures shrink with the box (convergent interval extension)
            spread = np.nanmax(g, axis=0) - np.nanmin(g, axis=0)
            finite = np.isfinite(hi - lo)
            assert np.median((hi - lo)[finite]) < 50 * np.median(spread[finite]) + 1e-12


def test_tripod_leg_lengths_match_the_mechanism_interface():
    from gpr_kinematics.mechanisms import load_mechanism
    mech = load_mechanism(config_path('mechanisms/tripod_3rps.yaml'))
    model = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))
    pts = _uniform(np.array([[0.05, 0.13], [-1.0, 1.0], [-1.0, 1.0]]), 200)
    poses = np.zeros((200, 6))
    poses[:, 2], poses[:, 3], poses[:, 4] = pts[:, 0], pts[:, 2], pts[:, 1]      # (x, y, z, theta, psi, phi)
    legs = mech.inverse_kinematics(mech.complete_pose(poses))
    assert np.allclose(model.evaluate(pts), legs, atol=1e-14)


def test_tripod_spherical_joints_stay_in_their_leg_planes():
    model = TripodModel()
    pts = _uniform(np.array([[0.05, 0.13], [-1.4, 1.4], [-1.4, 1.4]]), 500)
    a, s = model.joints(pts)
    tangent = np.stack([-np.sin(model.beta), np.cos(model.beta), np.zeros(3)], axis=1)
    assert np.max(np.abs(np.einsum('nki,ki->nk', s, tangent))) < 1e-15
    # upright platform at height z: every leg is sqrt((R - r)^2 + z^2) = z for R = r
    assert np.allclose(model.evaluate(np.array([[0.1, 0.0, 0.0]])), 0.1, atol=1e-16)


def test_rrr3_branch_is_the_papers_arcsin_formula_and_closes_the_legs():
    model = load_workspace_model(config_path('mechanisms/rrr3_planar.yaml'))
    assert isinstance(model, Rrr3PlanarModel)
    pts = _uniform(np.array([[-0.03, 0.03], [-0.03, 0.03], [-0.4, 0.4]]), 400)
    u = model.crank_directions(pts)
    ok = np.all(np.isfinite(u[..., 0]), axis=1)
    assert ok.sum() > 100
    pts, u = pts[ok], u[ok]
    x, y, phi = pts.T
    l1, l2, l3 = model.l1, model.l2, model.r
    for i in range(3):
        xi, yi = model.A[i]
        g = model.platform_angles[i]
        # Posypkin et al., eqs. (8)-(12)
        a_sin = 2 * (yi * l1 - y * l1 - l1 * l3 * np.sin(g + phi))
        a_cos = 2 * (xi * l1 - x * l1 - l1 * l3 * np.cos(g + phi))
        b_cos = x ** 2 + 2 * x * l3 * np.cos(g + phi) - 2 * x * xi + l3 ** 2 * np.cos(g + phi) ** 2 \
            - 2 * xi * l3 * np.cos(g + phi) + xi ** 2
        b_sin = y ** 2 + 2 * y * l3 * np.sin(g + phi) - 2 * y * yi + l3 ** 2 * np.sin(g + phi) ** 2 \
            - 2 * yi * l3 * np.sin(g + phi) + yi ** 2
        aux = np.arctan2(a_cos, a_sin)
        theta = np.arcsin((l2 ** 2 - l1 ** 2 - b_cos - b_sin) / np.hypot(a_sin, a_cos)) - aux
        assert np.allclose(np.cos(theta), u[:, i, 0], atol=1e-12)
        assert np.allclose(np.sin(theta), u[:, i, 1], atol=1e-12)
        # the elbow closes: |C_i - (A_i + l1 u)| = l2
        c = np.stack([x + l3 * np.cos(g + phi), y + l3 * np.sin(g + phi)], axis=1)
        assert np.allclose(np.linalg.norm(c - model.A[i] - l1 * u[:, i], axis=1), l2, atol=1e-15)
    # home pose: every input angle is 0 and inside the +-45 deg range
    assert np.allclose(model.input_angles(np.zeros((1, 3))), 0.0, atol=1e-15)
    assert model.feasible(np.zeros((1, 3)))[0]


def test_rrr3_angle_constraint_is_the_input_angle_range():
    model = Rrr3PlanarModel()
    pts = _uniform(model.box, 20000)
    g = model.evaluate(pts)
    ang = model.input_angles(pts)
    closes = np.all(g[:, :3] >= 0, axis=1)
    by_angle = np.all(np.abs(ang) <= math.pi / 4, axis=1) & closes
    assert np.array_equal(model.feasible(pts), by_angle)


def test_gpr_rods_tilt_and_displacements_match_the_core_forward_kinematics():
    from gpr_kinematics.core import forward_batch
    model = load_workspace_model(config_path('mechanisms/gpr.yaml'))
    assert isinstance(model, GprModel)
    pts = _uniform(np.array([[0.05, 0.45], [-0.15, 0.15], [-0.15, 0.15]]), 300)
    q = model.actuators(pts)
    fb = forward_batch(q, model='radial', check_limits=False)
    assert np.allclose(fb.tilt, np.hypot(pts[:, 1], pts[:, 2]), atol=1e-13)
    az = np.arctan2(pts[:, 2], pts[:, 1])
    assert np.allclose(np.angle(np.exp(1j * (fb.tilt_azimuth - az))), 0.0, atol=1e-10)
    assert np.allclose(q.mean(axis=1), pts[:, 0], atol=1e-15)
    g = model.evaluate(pts)
    assert np.allclose(np.abs(g[:, 3:6]), fb.joint_displacement, atol=1e-15)
    assert np.allclose(fb.virtual_joints - model.R, g[:, 3:6], atol=1e-15)
    assert np.array_equal(g[:, 6], np.abs(g[:, 3:6]).max(axis=1))   # dl_max, the largest
    # untilted: no displacement; within_budget agrees with the model's constraint
    assert np.all(model.evaluate(np.array([[0.2, 0.0, 0.0]]))[0, 3:] == 0.0)
    inside_budget = np.all(np.abs(g[:, 3:6]) <= model.budget, axis=1)
    assert np.array_equal(inside_budget, fb.within_budget)


def test_gpr_remainder_bound_holds_for_exact_displacements():
    """|dl - dl_lin| <= 1.5 e1^2 / R, the bound behind the certified enclosure (docs/workspace.md)."""
    model = GprModel()
    pts = _uniform(np.array([[0.2, 0.3], [-0.3, 0.3], [-0.3, 0.3]]), 2000)
    q = model.actuators(pts)
    dl = model.radial_displacements(q)
    pairs = ((0, 1), (1, 2), (2, 0))
    D = np.stack([(q[:, j] - q[:, i]) ** 2 for i, j in pairs], axis=1)
    lin = np.stack([D[:, 0] - D[:, 1] + D[:, 2], D[:, 0] + D[:, 1] - D[:, 2], D[:, 1] + D[:, 2] - D[:, 0]],
                   axis=1) / (6 * model.R)
    m = np.abs(lin).max(axis=1)
    e1 = 2 * m / (1 + np.sqrt(1 - 6 * m / model.R))
    assert np.all(np.abs(dl).max(axis=1) <= e1 * (1 + 1e-12))
    err = np.abs(dl - lin).max(axis=1)
    assert np.all(err <= 1.5 * e1 ** 2 / model.R * (1 + 1e-9))
    assert err.max() > 0.1 * (1.5 * e1 ** 2 / model.R).max()          # the bound is not vacuous


def test_closed_form_areas_and_volumes():
    # DexTAR with d = 0: two identical coincident annuli -> one annulus
    assert math.isclose(DextarModel(0.2, 0.1, 0.1, 0.2, 0.0).exact_area(), math.pi * (0.3 ** 2 - 0.1 ** 2))
    # shell arm with the floor below the shell: whole shell
    arm = ShellArmModel(0.3, 0.2, floor=-1.0)
    assert math.isclose(arm.exact_volume(), 4 / 3 * math.pi * (0.5 ** 3 - 0.1 ** 3))
    # floor through the centre: half the shell
    assert math.isclose(ShellArmModel(0.3, 0.2, floor=0.0).exact_volume(), arm.exact_volume() / 2)
    # Monte-Carlo agreement (5 sigma) for the packaged DexTAR and shell arm
    for name in ('dextar', 'shell_arm'):
        model = load_workspace_model(config_path(f'mechanisms/{name}.yaml'))
        exact = model.exact_area() if name == 'dextar' else model.exact_volume()
        n = 200_000
        frac = model.feasible(_uniform(model.box, n)).mean()
        vol = np.prod(model.box[:, 1] - model.box[:, 0])
        assert abs(frac * vol - exact) < 5 * vol * math.sqrt(frac * (1 - frac) / n)


def test_upu3_matches_the_mechanism_limb_lengths():
    from gpr_kinematics.mechanisms import load_mechanism
    mech = load_mechanism(config_path('mechanisms/upu3.yaml'))
    model = load_workspace_model(config_path('mechanisms/upu3.yaml'))
    assert isinstance(model, Upu3Model)
    pts = _uniform(model.box, 300)
    poses = np.zeros((300, 6))
    poses[:, :3] = pts
    assert np.allclose(model.evaluate(pts), mech.inverse_kinematics(poses), atol=1e-15)


@pytest.mark.parametrize('data, match', [
    ({'type': 'nope'}, 'unknown mechanism type'),
    ({'type': 'dextar', 'la': 0.2}, 'missing key lb'),
    ({'type': 'shell_arm', 'l1': 0.3, 'l2': 'x'}, 'l2 must be a positive finite length'),
    # one number rule for every YAML loader (schema.number_key): no bool, no string, however float() reads it
    ({'type': 'shell_arm', 'l1': True, 'l2': 0.2}, 'l1 must be a positive finite length'),
    ({'type': 'shell_arm', 'l1': '0.5', 'l2': 0.2}, 'l1 must be a positive finite length'),
    ({'type': 'dextar', 'la': 0.2, 'lb': 0.2, 'lc': 0.2, 'ld': 0.2, 'd': '0.1'}, 'd must be a finite length'),
    ({'type': 'rrr3_planar', 'base_radius': 0.1, 'platform_radius': 0.05, 'crank': 0.05, 'coupler': 0.05,
      'theta_min': '-0.5'}, 'theta_min must be a finite number in rad'),
    ({'type': 'rrr3_planar', 'base_radius': 0.1, 'platform_radius': 0.05, 'crank': 0.05, 'coupler': 0.05,
      'branch': 1.0}, 'branch must be 1 or -1'),
    ({'type': 'rrr3_planar', 'base_radius': 0.1, 'platform_radius': 0.05, 'crank': 0.05, 'coupler': 0.05,
      'theta_min': -4.0, 'theta_max': 3.0}, r'^test \(rrr3_planar\): theta_min = -4.0, theta_max = 3.0 rad; allowed: '
                                            r'theta_min < theta_max < theta_min \+ 2 pi'),   # the file named
    ({'type': 'rrr3_planar', 'base_radius': 0.1, 'platform_radius': 0.05, 'crank': 0.05, 'coupler': 0.05,
      'base_angles': [0, 1, True]}, r'base_angles\[2\] must be a finite number in rad'),
    ({'type': 'shell_arm', 'l1': 0.3, 'l2': 0.2, 'workspace': {'box': {'x': [False, 1]}}}, 'workspace.box.x'),
    ({'type': 'shell_arm', 'l1': 0.3, 'l2': 0.2, 'workspace': {'box': {'x': '0 1'}}}, r'must be \[lower, upper\]'),
    ({'type': 'gpr', 'workspace': {'max_tilt': '0.3'}}, 'max_tilt must be a positive finite number in rad'),
    # unknown keys are refused with their names, in every workspace file and in its workspace section
    ({'type': 'rrr3_planar', 'base_radius': 0.1, 'platform_radius': 0.05, 'crank': 0.05, 'coupler': 0.05,
      'brnch': -1}, 'unknown key.*brnch'),
    ({'type': 'dextar', 'la': 0.2, 'lb': 0.2, 'lc': 0.2, 'ld': 0.2, 'd': 0.2, 'links': 2}, 'unknown key.*links'),
    ({'type': 'shell_arm', 'l1': 0.3, 'l2': 0.2, 'flor': 0.0}, 'unknown key.*flor'),
    ({'type': 'shell_arm', 'l1': 0.3, 'l2': 0.2, 'workspace': {'bx': {}}}, 'workspace: unknown key.*bx'),
    ({'type': ['gpr']}, 'unknown mechanism type'),
    ({'type': 'shell_arm', 'l1': 0.3, 'l2': 0.2, 'workspace': {'box': {'w': [0, 1]}}}, 'unknown variable'),
    ({'type': 'shell_arm', 'l1': 0.3, 'l2': 0.2, 'workspace': {'box': {'x': [1, 0]}}}, 'lower < upper'),
    ({'type': 'gpr', 'workspace': {'virtual_joint_model': 'polar'}}, 'no certified enclosure'),
    # the model in the overrides: the radial enclosure's boxes were called certified for polar and compliant
    ({'type': 'gpr', 'overrides': {'model': 'polar'}}, "overrides model 'polar' has no certified enclosure"),
    ({'type': 'gpr', 'overrides': {'model': 'compliant', 'kappa': 1.0}}, "model 'compliant' has no certified"),
    ({'type': 'tripod_3rps', 'base_radius': 0.05}, 'leg_min'),
    ({'type': 'gpr', 'workspace': {'box': {'tilt_x': [-1.2, 1.2], 'tilt_y': [-1.2, 1.2]}}}, 'below 1.5 rad'),
    ({'type': 'gpr', 'overrides': {'rod_azimuths': [0.0, 2.0, 4.0]}}, 'three azimuths 120 deg apart'),
    # 2.4e-9 rad off: refused, its values shown in degrees to 6 digits read as 0, 120, 240 deg
    ({'type': 'gpr', 'overrides': {'rod_azimuths': [0, 2.0943951, 4.1887902]}},
     r'rod_azimuths \[0.0, 2.0943951, 4.1887902\] rad, their gaps \[-2.39\d*e-09, -2.39\d*e-09\] rad off 120 deg; '
     r'allowed: three azimuths 120 deg apart to 1e-09 rad'),
    ({'type': 'gpr', 'overrides': {'rod_offsets': [1e-4, 0.0, 0.0]}}, 'rod_offsets in overrides.*nominal machine'),
    # overrides the model does not use were accepted and ignored (same boxes): refused as rod_offsets was
    ({'type': 'gpr', 'overrides': {'kappa': 100}}, 'kappa in overrides.*nominal machine'),
    ({'type': 'gpr', 'overrides': {'tilt_limit': 0.1, 'max_iterations': 20}}, 'tilt_limit, max_iterations in over'),
    ({'type': 'gpr', 'overrides': {'characteristic_length': 0.2}}, 'characteristic_length in overrides'),
    ({'type': 'tripod_3rps', 'base_radius': 0.05, 'platform_radius': 0.05, 'leg_min': 0.07, 'leg_max': 0.13,
      'workspace': {'box': {'psi': [-2.0, 2.0]}}}, r'reaches 2 rad; allowed: at most pi/2'),
    ([1, 2], 'mapping'),
])
def test_bad_mechanism_descriptions_raise_config_errors(data, match):
    with pytest.raises(ConfigError, match=match):
        model_from_mapping(data, 'test')


def test_gpr_overrides_the_model_does_not_use_are_refused_with_the_keys_allowed():
    """``overrides={kappa: 100}`` gave the boxes of no overrides; the model's own keys are still taken."""
    with pytest.raises(ConfigError) as err:
        model_from_mapping({'type': 'gpr', 'overrides': {'kappa': 100}}, 'gpr.yaml')
    assert str(err.value) == ('gpr.yaml (gpr): kappa in overrides: the GPR workspace model is of the nominal machine '
                              '(radius, rod azimuths, stroke, budget) and does not use them; allowed: those keys only '
                              '(radius, rod_azimuths, stroke_min, stroke_max, imperfection_budget; model: radial)')
    model = model_from_mapping({'type': 'gpr', 'overrides': {'imperfection_budget': 0.001, 'model': 'radial'}}, 't')
    assert model.budget == 0.001


def test_a_path_that_is_no_path_is_refused_by_name():
    """load_workspace_model(5) raised a bare TypeError from os.fspath: the mechanisms' loader's refusal."""
    with pytest.raises(ConfigError) as err:
        load_workspace_model(5)
    assert str(err.value) == ('mechanism file path = 5; allowed: a file path (str or Path) of a mechanism YAML file, '
                              'or the name of a packaged one such as upu3.yaml')


def test_overrides_replace_parameters():
    model = model_from_mapping({'type': 'shell_arm', 'l1': 0.3, 'l2': 0.2}, 'test', {'l1': 0.4})
    assert model.l1 == 0.4


@pytest.mark.parametrize('make, match', [
    (lambda: TripodModel(base_radius=math.nan), 'base_radius = nan'),
    (lambda: TripodModel(angle_scale=0.0), 'angle_scale = 0.0'),
    (lambda: TripodModel(angle_scale=-0.05), 'angle_scale = -0.05'),
    (lambda: Upu3Model(b=math.inf), 'b = inf'),
    (lambda: Upu3Model(azimuths=(0.0, 1.0, math.nan)), r'azimuths\[2\] = nan'),
    (lambda: DextarModel(d=math.nan), 'd = nan'),
    (lambda: ShellArmModel(floor=math.nan), 'floor = nan'),
    (lambda: ShellArmModel(l2=math.inf), 'l2 = inf'),
    (lambda: GprModel(imperfection_budget=math.inf), 'imperfection_budget = inf'),
    (lambda: GprModel(stroke_max=math.nan), 'stroke_max = nan'),
    (lambda: Rrr3PlanarModel(crank=math.nan), 'crank = nan'),
    (lambda: Rrr3PlanarModel(base_angles=(0.0, 2.0, math.inf)), r'base_angles\[2\] = inf'),
])
def test_models_refuse_parameters_that_are_not_finite(make, match):
    """The Python API took NaN and infinite parameters (a NaN base radius gave a covering of nothing, 290 boxes
    'outside'; a NaN floor 1.1 million boundary boxes) and angle scales of 0 or below (the angles never bisected):
    each is refused, named, with what is allowed."""
    with pytest.raises(ConfigError, match=f'{match}; allowed: a (positive )?(finite number|length from 1e-06 to '
                                          r'1e\+06 m)'):
        make()
    assert ShellArmModel(floor=-math.inf).lower[1] == -math.inf        # no floor: still allowed


@pytest.mark.parametrize('make, match', [
    (lambda: TripodModel(angle_scale=1e-300), r'angle_scale = 1e-300; allowed: a length from 1e-06 to 1e\+06 m \(m '
                                              r"per rad: the angles' weight in a box's diameter\)"),
    (lambda: TripodModel(base_radius=5e-324), r'base_radius = 5e-324; allowed: a length from 1e-06 to 1e\+06 m$'),
    (lambda: Rrr3PlanarModel(coupler=2e6), r'coupler = 2000000.0; allowed: a length from 1e-06'),
    (lambda: GprModel(angle_scale=1e-7), r'angle_scale = 1e-07; allowed: a length from 1e-06'),
])
def test_models_refuse_lengths_and_angle_scales_beyond_the_packages_lengths(make, match):
    """An attacker's review: an ``angle_scale`` of 1e-300 (the angles never bisected: 16 boundary boxes over the
    whole box) and a subnormal radius passed; lengths and angle scales are held to the core's least length and the
    coordinates' bound, as a mechanism's characteristic length is. Their least and most are taken."""
    with pytest.raises(ConfigError, match=match):
        make()
    assert TripodModel(angle_scale=1e-6).scale[1] == 1e-6 and TripodModel(base_radius=1e6).R == 1e6


def test_tripod_joint_directions_enclose_the_exact_120_and_240_degrees():
    """The legs' enclosure took cos/sin of the float azimuths 2 pi/3, 4 pi/3 one ulp either side: [-0.49999999999999983,
    -0.4999999999999997] for cos 120 deg, which misses the real -1/2 (and sin 240 deg missed -sqrt(3)/2): the
    certified legs were those of joints turned by about 1e-16 rad. The enclosures now hold the exact values, and
    the point formulas use their nearest floats."""
    from fractions import Fraction

    mpmath = pytest.importorskip('mpmath')
    model = TripodModel()
    exact_cos = [Fraction(1), Fraction(-1, 2), Fraction(-1, 2)]
    for c, s, ec, sign in zip(model.unit_cos, model.unit_sin, exact_cos, (0, 1, -1), strict=True):
        assert Fraction(float(c.lo)) <= ec <= Fraction(float(c.hi))
        lo, hi = Fraction(float(s.lo)), Fraction(float(s.hi))
        if sign == 0:
            assert lo <= 0 <= hi
        else:                                   # sign * sqrt(3)/2 in [lo, hi]  <=>  lo^2, hi^2 bracket 3/4
            assert (lo <= 0 <= hi) is False and sorted([lo * lo, hi * hi])[0] <= Fraction(3, 4) <= max(lo * lo, hi * hi)
            assert (lo > 0) == (sign > 0)
    # leg lengths against 40-digit arithmetic with the exact azimuths, the parasitic motions of eqs. 2-3
    mp = mpmath.mp.clone() if hasattr(mpmath.mp, 'clone') else mpmath.mp
    mp.dps = 40
    pts = np.array([[0.1, 0.3, -0.2], [0.09, -0.7, 0.5], [0.12, 1.2, 1.1]])
    for z, psi, th in pts:
        ps, t = mp.mpf(float(psi)), mp.mpf(float(th))
        phi = mp.atan(mp.sin(ps) * mp.sin(t) / (mp.cos(ps) + mp.cos(t)))
        Ry = mp.matrix([[mp.cos(t), 0, mp.sin(t)], [0, 1, 0], [-mp.sin(t), 0, mp.cos(t)]])
        Rx = mp.matrix([[1, 0, 0], [0, mp.cos(ps), -mp.sin(ps)], [0, mp.sin(ps), mp.cos(ps)]])
        Rz = mp.matrix([[mp.cos(phi), -mp.sin(phi), 0], [mp.sin(phi), mp.cos(phi), 0], [0, 0, 1]])
        Rp = Ry * Rx * Rz
        centre = mp.matrix([mp.mpf(model.r) / 2 * (Rp[0, 0] - Rp[1, 1]), -mp.mpf(model.r) * Rp[1, 0], mp.mpf(float(z))])
        legs = Interval.point(np.array([z])), Interval.point(np.array([psi])), Interval.point(np.array([th]))
        enc = model.legs(*legs)
        for i, deg in enumerate((0, 120, 240)):
            u = mp.matrix([mp.cos(mp.pi * deg / 180), mp.sin(mp.pi * deg / 180), 0])
            leg = mp.norm(centre + mp.mpf(model.r) * (Rp * u) - mp.mpf(model.R) * u)
            assert mp.mpf(float(enc[i].lo[0])) <= leg <= mp.mpf(float(enc[i].hi[0])), (i, z, psi, th)
            assert abs(float(leg) - model.evaluate(np.array([[z, psi, th]]))[0, i]) < 1e-16


def test_dextar_closed_form_area_next_to_a_tangency():
    """Two circles of the annuli tangent to rounding (0.05 + 0.55 = 0.6 = d here): math.acos got a cosine beyond 1
    and exact_area raised 'math domain error'. The area now matches a fine midpoint grid over annulus 1."""
    model = DextarModel(0.05, 0.1, 0.15, 0.4, 0.6)
    area = model.exact_area()
    n = 2000
    x = 0.15 + 0.3 * (np.arange(n) + 0.5) / n                  # annulus 1 lies in [0.15, 0.45] x [-0.15, 0.15]
    y = -0.15 + 0.3 * (np.arange(n) + 0.5) / n
    X, Y = np.meshgrid(x, y)
    grid = model.feasible(np.column_stack([X.ravel(), Y.ravel()])).sum() * (0.3 / n) ** 2
    assert abs(area - grid) < 0.003 * area
    for lengths in ((0.05, 0.1, 0.2, 0.35, 0.6), (0.05, 0.1, 0.25, 0.4, 0.7), (0.3, 0.1, 0.15, 0.15, 0.1)):
        assert 0.0 <= DextarModel(*lengths).exact_area() < math.pi * 0.4 ** 2


def test_lens_area_next_to_an_internal_tangency():
    """Discs of radii 0.61 and 0.73 whose centres are |r1 - r2| plus an ulp apart (the small one inside the large
    one, touching it): there the cosine of the small disc's half-angle rounds to -1.0000000000000002, below -1; the
    lens is the whole small disc, pi r1^2, to rounding (math.acos raised 'math domain error' without the clamp)."""
    from gpr_kinematics.workspace.dextar import _lens_area
    r1, r2, d = 0.610569418009508, 0.7322015953741584, 0.12163217736465039
    assert (d * d + r1 * r1 - r2 * r2) / (2 * d * r1) < -1.0 and d > abs(r1 - r2)
    assert math.isclose(_lens_area(r1, r2, d), math.pi * r1 ** 2, rel_tol=1e-7)
    assert math.isclose(_lens_area(r2, r1, d), math.pi * r1 ** 2, rel_tol=1e-7)


def test_rrr3_whose_home_pose_does_not_close_is_refused():
    """The input range is measured from the cranks' directions at the home pose; with crank 0.02 and coupler 0.1 no
    leg closes there (|C - A| = 0.05 < 0.08), the directions were NaN and every pose came out infeasible, though
    (0, 0, pi/2) closes all three legs. Such a geometry is refused, named."""
    with pytest.raises(ConfigError, match=r'home pose x = y = phi = 0 does not close leg 1 \(\|C - A\| = 0\.05 m, '
                                          r'outside \[0\.08, 0\.12\] m\)'):
        Rrr3PlanarModel(crank=0.02, coupler=0.1)
    data = {'type': 'rrr3_planar', 'base_radius': 0.1, 'platform_radius': 0.05, 'crank': 0.02, 'coupler': 0.1}
    with pytest.raises(ConfigError, match='does not close leg 1'):
        model_from_mapping(data)
    assert np.all(np.isfinite(Rrr3PlanarModel().m))


@pytest.mark.parametrize('azimuths, message', [
    ([0.0, 0.0, 0.0], r'upu3: azimuths \[0\.0, 0\.0, 0\.0\] rad: limbs 1 and 2 share an azimuth'),
    ([0.0, 2.0, 2 * math.pi], r'upu3: azimuths \[0\.0, 2\.0, 6\.283185307\] rad: limbs 1 and 3 share an azimuth'),
    ([1.0, 3.0, 3.0 - 4 * math.pi], r'limbs 2 and 3 share an azimuth \(mod 2 pi\), one joint pair for two limbs; '
                                    r'allowed: three azimuths at least 1e-06 rad apart modulo 2 pi'),
    ([0.0, 1.0], r'upu3: azimuths must be 3 finite angles in rad; got \[0\.0, 1\.0\]'),
])
def test_upu3_workspace_model_refuses_limbs_sharing_an_azimuth(azimuths, message):
    """Upu3Model built in Python took [0, 0, 0] (three limbs on one joint pair, three equal constraint centres):
    it checks the azimuths with the mechanism's own check (mechanisms.upu3.check_azimuths)."""
    with pytest.raises(ConfigError, match=message):
        Upu3Model(azimuths=azimuths)
    model = Upu3Model(azimuths=[0.0, 2e-6, 4.0])               # distinct by twice the least gap: taken
    np.testing.assert_allclose(model.centres[:, 0], 0.03 * np.cos([0.0, 2e-6, 4.0]))


@pytest.mark.parametrize('kwargs, message', [
    ({'base_angles': [0.0, 0.0, 0.0]}, r'rrr3_planar: legs 1 and 2 join the same base pivot and platform joint '
                                       r'\(base_angles \[0\.0, 0\.0, 0\.0\], platform_angles \[0\.0, 0\.0, 0\.0\] '
                                       r'rad\): one leg given twice; allowed: legs whose base or platform angles '
                                       r'differ'),
    ({'base_angles': [math.pi / 2, 5 * math.pi / 2, 11 * math.pi / 6]}, r'legs 1 and 2 join the same base pivot'),
    ({'base_angles': [0.0, 1.0, 1.0 + 2 * math.pi]}, r'legs 2 and 3 join'),
])
def test_rrr3_workspace_model_refuses_one_leg_given_twice(kwargs, message):
    """base_angles [0, 0, 0] (or two equal modulo 2 pi, the platform's angles the base's) were covered as a "certified"
    workspace of three constraints, two of them one leg. Two legs sharing a base pivot alone are a design: taken."""
    with pytest.raises(ConfigError, match=message):
        Rrr3PlanarModel(**kwargs)
    given = [math.pi / 2, 7 * math.pi / 6, 11 * math.pi / 6]     # the defaults, given: taken
    assert Rrr3PlanarModel(platform_angles=given).platform_angles.tolist() == given
    with pytest.raises(ConfigError, match='the home pose'):        # one pivot, two platform joints: past this check
        Rrr3PlanarModel(base_angles=[0.0, 0.0, 2.0], platform_angles=[0.0, 2.0, 4.0])


def test_gpr_tan_over_sqrt_is_accurate_on_both_sides_of_its_series_switch():
    """``tan(sqrt(u)) / sqrt(u)`` (the series 1 + u/3 + 2u^2/15 below u = 1e-8) within 2^-50 of mpmath's value, from
    u = 0 to tilts of 1.5 rad: the monotone enclosure of the GPR's rod lengths allows 2^-48."""
    mpmath = pytest.importorskip('mpmath')
    from gpr_kinematics.workspace.gpr import _tan_over
    mp = mpmath.mp.clone() if hasattr(mpmath.mp, 'clone') else mpmath.mp
    mp.prec = 120
    u = np.concatenate([[0.0, 5e-324, 1e-20, 1e-12, 0.999e-8, np.nextafter(1e-8, 0), 1e-8, 1.001e-8, 1e-6],
                        10.0 ** RNG.uniform(-10, np.log10(1.5 ** 2), 200)])
    got = _tan_over(u)
    for ui, gi in zip(u, got, strict=True):
        s = mp.sqrt(mp.mpf(float(ui)))
        exact = mp.tan(s) / s if ui > 0 else mp.mpf(1)
        assert abs(mp.mpf(float(gi)) - exact) <= 2.0 ** -50 * exact, (ui, gi)


def test_gpr_enclosures_of_point_like_boxes_hold_the_exact_displacements():
    """Boxes 1e-9 wide at tilts up to 0.3 rad: there the linear part of the displacements is enclosed tightly and
    the remainder bound (1.5 e1^2 / R, e1 from the linear part) does the work; the exact displacements (Newton on
    the side lengths) must lie inside, the rod lengths too. Up to 1 rad, where the bound's condition 6 m < R fails
    for most boxes, the enclosure must hold them still."""
    model = GprModel(box=np.array([[0.0, 0.5], [-1.0, 1.0], [-1.0, 1.0]]))
    for tilt in (0.3, 1.0):
        pts = _uniform(np.array([[0.1, 0.4], [-tilt, tilt], [-tilt, tilt]]), 400)
        boxes = np.stack([pts, pts + 1e-9], axis=2)
        lo, hi = model.bounds(boxes)
        g = model.evaluate(pts)
        assert np.all(np.isfinite(g)) and np.all(lo <= g) and np.all(g <= hi), tilt
        if tilt == 0.3:
            assert np.median((hi - lo)[:, 3:]) < 0.5 * np.median(np.abs(g[:, 3:]))      # and not vacuous


def _assert_box_holds_feasible(model, wide: np.ndarray, at_least: int) -> None:
    """Of 200,000 points drawn from ``wide``, more than ``at_least`` are feasible, and every feasible one lies in the
    model's default box."""
    pts = _uniform(wide, 200_000)
    ok = model.feasible(pts)
    assert ok.sum() > at_least
    inside = np.all((pts >= model.box[:, 0]) & (pts <= model.box[:, 1]), axis=1)
    assert inside[ok].all()


@pytest.mark.parametrize('kwargs', [{}, {'base_radius': 0.05, 'platform_radius': 0.15, 'crank': 0.1, 'coupler': 0.1,
                                         'theta_min': -3.0, 'theta_max': 3.0}])
def test_rrr3_default_box_holds_every_feasible_pose(kwargs):
    """The planar model's default box must contain its working area (the covering reports only what lies in it):
    poses sampled from a box 1.5 times as wide, in x, y and over the whole turn of phi, are feasible only inside it
    (the second geometry, cranks turning +-3 rad, reaches |x| = 0.125 m, beyond its coupler length)."""
    model = Rrr3PlanarModel(**kwargs)
    wide = model.box.copy()
    wide[:2] *= 1.5
    _assert_box_holds_feasible(model, wide, 100)


def test_upu3_default_box_holds_every_feasible_position():
    """The 3-UPU model's default box (limb_max + |b - p| around the axis, z from 0 to limb_max) must contain its
    working area above the base: positions sampled from a box twice as wide are feasible only inside it."""
    _assert_box_holds_feasible(Upu3Model(), np.array([[-0.6, 0.6], [-0.6, 0.6], [0.0, 0.6]]), 1000)


def test_shell_arm_with_the_shorter_upper_arm_keeps_its_hole():
    """The shell |l1 - l2| <= |P| <= l1 + l2 is the same for l1 < l2: the arm 0.2 + 0.3 cannot reach within 0.1 m
    of its shoulder (the lower bound of the reach constraint is 0.1, not -0.1), and its volume is the shell's."""
    arm = ShellArmModel(0.2, 0.3, floor=-1.0)
    assert arm.lower[0] == pytest.approx(0.1)
    points = np.array([[0.05, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.55]])
    assert arm.feasible(points).tolist() == [False, True, False]
    assert math.isclose(arm.exact_volume(), 4 / 3 * math.pi * (0.5 ** 3 - 0.1 ** 3))
