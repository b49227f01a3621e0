"""The joint working area of the tripod over the planar 3-RRR: points of its inner boxes are realised by explicit
poses of the two mechanisms found here, random pose pairs land in its outer boxes, the placement is an
explicit and effective assumption, and bad descriptions are refused."""
import time

import numpy as np
import pytest
from gpr_kinematics.errors import ConfigError, InputError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.workspace import approximate, contains_points, load_workspace_model, model_from_mapping
from gpr_kinematics.workspace.joint_area import JointWorkingArea
from gpr_kinematics.workspace.voxels import MAX_VOXELS, VoxelSet

RNG = np.random.default_rng(23)
DELTA = 0.008


@pytest.fixture(scope='module')
def joint():
    model = load_workspace_model(config_path('mechanisms/joint_working_area.yaml'))
    return model, approximate(model, DELTA)


@pytest.mark.slow
def test_the_reported_time_includes_the_mechanisms_coverings():
    """result.seconds is the whole run's: the tripod's and the planar mechanism's coverings (about half the work)
    included (they were left out)."""
    model = load_workspace_model(config_path('mechanisms/joint_working_area.yaml'))
    t0 = time.perf_counter()
    res = approximate(model, 2 * DELTA)
    wall = time.perf_counter() - t0
    assert 0.9 * wall <= res.seconds <= wall


def _feasible_poses(model, n):
    """Random feasible tripod poses (z, psi, theta) and planar poses (x, y, phi), by rejection."""
    out = []
    for mech, m in ((model.tripod, 20 * n), (model.planar, 60 * n)):
        pts = mech.box[:, 0] + (mech.box[:, 1] - mech.box[:, 0]) * RNG.random((m, 3))
        pts = pts[mech.feasible(pts)]
        out.append(pts[RNG.integers(0, pts.shape[0], n)])
    return out


def _realise(model, p, tries=20000):
    """Search poses of both mechanisms whose tool point is ``p`` (3,): for random tilts and turns, the tripod's
    z follows from the height (the tool point is affine in z: two evaluations) and the planar pose from the
    horizontal closure; returns (tripod pose, planar pose) of a feasible pair, or None."""
    tilt = RNG.uniform(-1.45, 1.45, (tries, 2))
    phi = RNG.uniform(-np.pi, np.pi, tries)
    zero = np.zeros((tries, 3))
    at0 = model.tool_points(np.column_stack([np.zeros(tries), tilt]), zero)       # planar pose 0: p = P0
    at1 = model.tool_points(np.column_stack([np.full(tries, 0.1), tilt]), zero)
    z = (p[2] - at0[:, 2]) / ((at1[:, 2] - at0[:, 2]) / 0.1)
    P0 = at0 + (at1 - at0) * (z / 0.1)[:, None]
    c, s = np.cos(phi), np.sin(phi)
    planar = np.column_stack([P0[:, 0] - (c * p[0] - s * p[1]), P0[:, 1] - (s * p[0] + c * p[1]), phi])
    tripod = np.column_stack([z, tilt])
    ok = model.tripod.feasible(tripod) & model.planar.feasible(planar)
    inside = np.all((tripod >= model.tripod.box[:, 0]) & (tripod <= model.tripod.box[:, 1]), axis=1)
    ok &= inside & np.all((planar >= model.planar.box[:, 0]) & (planar <= model.planar.box[:, 1]), axis=1)
    if not ok.any():
        return None
    i = int(np.argmax(ok))
    return tripod[i], planar[i]


@pytest.mark.slow
def test_inner_points_are_realised_by_explicit_poses(joint):
    model, res = joint
    assert res.certified and not res.interrupted and res.inner_boxes > 20
    idx = RNG.integers(0, res.inner_boxes, 60)
    b = res.inner[idx]
    pts = b[:, :, 0] + (b[:, :, 1] - b[:, :, 0]) * RNG.random((60, 3))
    for p in pts:
        found = _realise(model, p)
        assert found is not None, p
        tripod, planar = found
        assert np.allclose(model.tool_points(tripod[None], planar[None])[0], p, atol=1e-12)


@pytest.mark.slow
def test_random_pose_pairs_land_in_the_outer_approximation(joint):
    model, res = joint
    tripod, planar = _feasible_poses(model, 50000)
    p = model.tool_points(tripod, planar)
    assert np.all(contains_points(np.concatenate([res.inner, res.boundary]), p))
    # the outer boxes all lie in the covering's box, itself inside the bound proved from the two mechanisms
    assert not res.touches_initial_box and np.all(model.box[:, 0] <= p.min(axis=0))
    # certified but not tight at this delta: the inner volume is below the sampled volume, the outer above it
    hits = np.unique(np.floor(p / 0.004).astype(int), axis=0).shape[0] * 0.004 ** 3
    assert res.inner_volume < hits < res.outer_volume


@pytest.mark.slow
def test_the_placement_is_an_explicit_assumption():
    base = load_workspace_model(config_path('mechanisms/joint_working_area.yaml'))
    up = JointWorkingArea(base.tripod, base.planar, translation=[0.0, 0.0, 0.25])
    a, b = approximate(base, 0.016), approximate(up, 0.016)
    za = np.concatenate([a.inner, a.boundary])[:, 2]
    zb = np.concatenate([b.inner, b.boundary])[:, 2]
    # raising the tripod by 5 cm raises every tool point by 5 cm (pz = P0_z): the outer hull follows
    assert abs((zb[:, 0].min() - za[:, 0].min()) - 0.05) <= 0.016
    assert abs((zb[:, 1].max() - za[:, 1].max()) - 0.05) <= 0.016
    tripod, planar = _feasible_poses(base, 2000)
    assert np.allclose(up.tool_points(tripod, planar)[:, 2] - base.tool_points(tripod, planar)[:, 2], 0.05, atol=1e-15)
    with pytest.raises(ConfigError, match='tilts the tripod axis'):
        JointWorkingArea(base.tripod, base.planar, rpy=[np.pi / 2, 0.0, 0.0])


@pytest.mark.parametrize('change, match', [
    ({'tripod': 'upu3.yaml'}, 'tripod must be a tripod_3rps mechanism, got type upu3'),
    ({'tripod': 'joint_working_area.yaml'}, 'must be a tripod_3rps mechanism, got type joint_working_area'),
    ({'planar': {'type': 'rrr3_planar', 'base_radius': 0.1}}, 'missing key platform_radius'),
    ({'planar': 7}, 'must be a mechanism file name or mapping'),
    ({'placement': {'translation': [0, 0]}}, 'placement.translation must be a list of 3 numbers'),
    ({'placement': {'shift': [0, 0, 0]}}, 'unknown key.*shift'),
    ({'placement': {'rpy': [0, 0, '1']}}, r"placement.rpy\[2\] = '1' is invalid; allowed: a finite angle in rad"),
    # radians only: a yaw of 90 (degrees meant) turned the planar part by 90 rad modulo 2 pi, silently
    ({'placement': {'rpy': [3.14159, 0, 90]}}, r'placement.rpy\[2\] = 90 rad is beyond one turn; allowed: '
                                                r'\[-2pi, 2pi\] rad \(radians only here: 90 deg is 1.57079633 rad\)$'),
    ({'tool': [0, 0, True]}, r'tool\[2\] must be a finite length'),
    ({'sub_delta': 2.0}, 'sub_delta in \\(0, 1\\]'),
    ({'tool_lenght': 0.1}, 'unknown key.*tool_lenght'),
])
def test_bad_joint_descriptions_are_refused(change, match):
    data = {'type': 'joint_working_area', 'tripod': 'tripod_3rps.yaml', 'planar': 'rrr3_planar.yaml', **change}
    with pytest.raises(ConfigError, match=match):
        model_from_mapping(data, 'joint')


@pytest.mark.slow
def test_a_box_that_misses_the_reachable_range_is_refused():
    data = {'type': 'joint_working_area', 'tripod': 'tripod_3rps.yaml', 'planar': 'rrr3_planar.yaml',
            'workspace': {'box': {'pz': [5.0, 6.0]}}}
    model = model_from_mapping(data, 'joint')
    with pytest.raises(ConfigError, match=r'workspace.box pz = \[5, 6\] misses the reachable range'):
        approximate(model, DELTA)


def test_voxel_sets_never_miss_a_box_they_hold():
    lo = RNG.random((300, 3))
    boxes = np.stack([lo, lo + 0.1 * RNG.random((300, 3))], axis=2)
    vox = VoxelSet.from_boxes(boxes, np.array([0.01, 0.02, 0.005]))
    assert np.all(vox.spacing == [2 ** -7, 2 ** -6, 2 ** -8])                   # dyadic, rounded down
    q = RNG.random((20000, 3)) * 1.4 - 0.2
    qb = np.stack([q, q + 0.03 * RNG.random((20000, 3))], axis=2)
    meets = np.array([np.any(np.all((b[:, 0] <= boxes[:, :, 1]) & (b[:, 1] >= boxes[:, :, 0]), axis=1)) for b in qb])
    hit = vox.any(qb[:, :, 0], qb[:, :, 1])
    assert np.all(hit[meets]) and 0 < np.count_nonzero(hit & ~meets) < np.count_nonzero(~meets)
    # degenerate query boxes (points) and boxes beyond the grid
    assert vox.any(boxes[:, :, 0], boxes[:, :, 0]).all()
    assert not vox.any(np.full((1, 3), 5.0), np.full((1, 3), 6.0))[0]
    with pytest.raises(Exception, match=f'limit of {MAX_VOXELS} voxels'):
        VoxelSet.from_boxes(boxes, np.full(3, 1e-4))


@pytest.mark.parametrize('limits, stopped', [({'max_boxes': 20000}, 'box limit (20000 boxes)'),
                                             ({'max_seconds': 0.3}, 'time limit (0.3 s)')])
def test_a_mechanism_covering_stopped_early_stops_the_run_for_its_reason(limits, stopped):
    """When the tripod's or the planar mechanism's own covering hit a limit, the run said 'interrupted' (as for
    Ctrl-C) after 0.0 s, though it had worked until the limit: it now says which limit, and the time spent."""
    model = model_from_mapping({'type': 'joint_working_area', 'tripod': 'tripod_3rps.yaml',
                                'planar': 'rrr3_planar.yaml', 'sub_delta': 1e-3})
    t0 = time.perf_counter()
    res = approximate(model, 0.006, **limits)
    wall = time.perf_counter() - t0
    assert res.interrupted and res.stopped == stopped
    assert 0.5 * wall <= res.seconds <= wall
    assert res.inner_boxes == 0 and res.boundary_boxes == 1       # nothing proved: the whole box is boundary


def test_the_tripods_early_stop_stops_the_run_before_the_planar_covering(monkeypatch):
    """The tripod's covering stopped on its box limit after 11 s, yet the planar mechanism was covered on until the
    run's time limit (147 s without one), and a stop of the planar one (SIGTERM) was reported as the tripod's:
    the run stops at the first covering that stops, with its reason."""
    from gpr_kinematics.workspace import joint_area

    model = model_from_mapping({'type': 'joint_working_area', 'tripod': 'tripod_3rps.yaml',
                                'planar': 'rrr3_planar.yaml', 'sub_delta': 1e-3})

    def never(_model):
        raise AssertionError('the planar mechanism was covered after the tripod stopped')

    monkeypatch.setattr(joint_area, 'compiled', never)
    res = approximate(model, 0.006, max_boxes=20000)
    assert res.interrupted and res.stopped == 'box limit (20000 boxes)'


def test_an_interrupted_planar_covering_stops_the_run_with_its_reason(monkeypatch):
    """The planar mechanism's covering stopped early: its boxes are not a covering, and the run stops with its
    reason (used as complete, a partial result would pass as valid; the tripod's reason was named before)."""
    from gpr_kinematics.workspace import covering

    model = model_from_mapping({'type': 'joint_working_area', 'tripod': 'tripod_3rps.yaml',
                                'planar': 'rrr3_planar.yaml', 'sub_delta': 0.5})
    real = covering.approximate
    calls: list[str] = []

    def part(sub_model, sub_delta, *args, **kwargs):
        calls.append(type(sub_model).__name__)
        if len(calls) == 2:   # the planar one, after the tripod's
            kwargs['max_boxes'] = 50
        return real(sub_model, sub_delta, *args, **kwargs)

    monkeypatch.setattr(covering, 'approximate', part)
    res = real(model, 0.006)
    assert len(calls) == 2 and res.interrupted and res.stopped == 'box limit (50 boxes)', (calls, res.stopped)


def test_a_sub_coverings_reasons_name_the_runs_time_limit(monkeypatch):
    """A sub-covering's reasons are several where two limits struck ('box limit (...); time limit (4.99997 s)'):
    its time limit is the time left of the run's, named as the run's, in place ('time limit (5 s)')."""
    from gpr_kinematics.workspace.covering import SubCoveringStoppedError

    model = model_from_mapping({'type': 'joint_working_area', 'tripod': 'tripod_3rps.yaml',
                                'planar': 'rrr3_planar.yaml', 'sub_delta': 1e-3})

    def stopped(delta, part):
        raise SubCoveringStoppedError('box limit (7 boxes); time limit (4.99997 s)')

    monkeypatch.setattr(model, 'covering_task', stopped)
    res = approximate(model, 0.006, max_seconds=5.0)
    assert res.interrupted and res.stopped == 'box limit (7 boxes); time limit (5 s)'


def test_voxel_sets_hit_within_two_voxels_of_a_box_and_never_beyond_three():
    """The margins of the voxel set, one voxel around every box when marking and one around the query box when
    counting: a query box less than two voxels (of its axis) from a box on every axis is always hit, and one three
    or more voxels away from every box on some axis never is (the marked index range ends one past the box's
    last voxel, the counted one starts one before the query's first: they share a voxel only when the gap is
    below three). Queries are placed at gaps of 0 to 5 voxels on either side of a box along one axis."""
    rng = np.random.default_rng(41)
    lo = rng.random((60, 3))
    boxes = np.stack([lo, lo + 0.1 * rng.random((60, 3))], axis=2)
    vox = VoxelSet.from_boxes(boxes, np.array([0.01, 0.02, 0.005]))
    s = vox.spacing
    n = 6000
    k, axis, side = rng.integers(0, 60, n), rng.integers(0, 3, n), rng.integers(0, 2, n)
    size = 0.5 * s * rng.random((n, 3))
    start = boxes[k, :, 0] + (boxes[k, :, 1] - boxes[k, :, 0]) * rng.random((n, 3))   # overlaps box k off the axis
    qlo, qhi = start.copy(), start + size
    rows = np.arange(n)
    gap = 5.0 * s[axis] * rng.random(n)
    below = side == 0
    qhi[rows[below], axis[below]] = boxes[k[below], axis[below], 0] - gap[below]
    qlo[rows[below], axis[below]] = qhi[rows[below], axis[below]] - size[rows[below], axis[below]]
    qlo[rows[~below], axis[~below]] = boxes[k[~below], axis[~below], 1] + gap[~below]
    qhi[rows[~below], axis[~below]] = qlo[rows[~below], axis[~below]] + size[rows[~below], axis[~below]]
    # per query and box: the gap along each axis in voxels of that axis (0 where they overlap)
    g = np.maximum(np.maximum(boxes[None, :, :, 0] - qhi[:, None, :], qlo[:, None, :] - boxes[None, :, :, 1]), 0.0) / s
    near = np.any(np.all(g < 1.999, axis=2), axis=1)
    far = ~np.any(np.all(g < 3.001, axis=2), axis=1)                  # a thousandth of a voxel for rounding
    hit = vox.any(qlo, qhi)
    assert near.sum() > 1000 and far.sum() > 1000
    assert hit[near].all() and not hit[far].any()


def test_a_tool_grid_beyond_the_voxel_limit_is_refused_before_the_planar_covering(monkeypatch):
    """``--delta 1 --mm`` covered the tripod and the planar mechanism (87 s, 710 MB) before its tool points' grid of
    27.5 million voxels was refused, with no word of which delta would do: refused after the tripod's covering now
    (the planar one never runs), naming the delta from which the dyadic grid fits; the grid of that delta fits."""
    from types import SimpleNamespace

    from gpr_kinematics.workspace import joint_area
    from gpr_kinematics.workspace.voxels import grid, hull_of
    model = load_workspace_model(config_path('mechanisms/joint_working_area.yaml'))
    box = np.asarray(model.tripod.box, dtype=float)[None]
    whole = SimpleNamespace(interrupted=False, inner=box, boundary=box[:0], stopped='')   # every tripod pose

    def cover(sub_model, _sub, *_args):
        assert sub_model is model.tripod, 'the planar mechanism was covered before the grid was refused'
        return whole

    monkeypatch.setattr(joint_area, 'compiled', lambda m: m)
    with pytest.raises(Exception, match=r'a voxel grid of \[\d+, \d+, \d+\] cells exceeds the limit of 16000000 '
                                        r'voxels; allowed: a coarser delta \(delta 0.001 here; ([\d.e-]+) or '
                                        r'more\)$') as info:
        model.covering_task(1e-3, cover)
    coarser = float(str(info.value).rsplit('here; ', 1)[1].split(' ')[0])
    box_points = model.tool_point(*(joint_area.Interval(box[0, i, 0], box[0, i, 1]) for i in range(3)))
    hull = hull_of(np.stack([np.stack([np.asarray(p.lo), np.asarray(p.hi)], axis=-1) for p in box_points],
                            axis=0)[None])
    step = np.full(3, model.sub_delta * coarser / 2)   # the named delta itself (it was rounded to the nearest)
    assert np.prod(grid(hull, step)[2].astype(float)) <= MAX_VOXELS
    with pytest.raises(Exception, match='exceeds the limit'):   # the power of two below does not fit
        grid(hull, step / 2)


def test_a_planar_grid_beyond_the_voxel_limit_names_the_delta(monkeypatch):
    """The planar mechanism's voxel sets (its outer boxes, and those not inner) over a grid beyond the limit: refused
    naming the covering's delta and about the coarsest one from which the grid fits, as the tool points' grid is
    (a tripod of one small pose box: its tool grid fits; the planar covering is its whole box)."""
    from types import SimpleNamespace

    from gpr_kinematics.workspace import joint_area
    from gpr_kinematics.workspace.voxels import grid
    model = load_workspace_model(config_path('mechanisms/joint_working_area.yaml'))
    tripod = np.array([[[0.07, 0.07 + 1e-6], [0.1, 0.1 + 1e-6], [-0.2, -0.2 + 1e-6]]])
    planar = np.asarray(model.planar.box, dtype=float)[None]
    covered = []

    def cover(sub_model, _sub, *_args):
        covered.append(sub_model)
        boxes = tripod if sub_model is model.tripod else planar
        return SimpleNamespace(interrupted=False, inner=boxes, boundary=boxes[:0], outside=boxes[:0], stopped='')

    monkeypatch.setattr(joint_area, 'compiled', lambda m: m)
    with pytest.raises(InputError) as info:
        model.covering_task(1e-3, cover)
    assert covered == [model.tripod, model.planar]
    assert str(info.value) == ('a voxel grid of [824, 824, 1614] cells exceeds the limit of 16000000 voxels; allowed: '
                               'a coarser delta (delta 0.001 here; 0.00782 or more)')
    step = np.full(3, model.sub_delta * 0.00782 / 2) / model.planar.scale
    assert np.prod(grid(planar[0], step)[2].astype(float)) <= MAX_VOXELS
    with pytest.raises(Exception, match='exceeds the limit'):   # the power of two below does not fit
        grid(planar[0], step / 2)


def test_the_coarser_delta_a_voxel_refusal_names_fits():
    """The delta a refusal names is one the grid takes: rounded to the nearest at three digits, below the
    spacing's doubling (`--delta 1 --mm` was told 'about 0.00195 or more', and 1.95 mm was refused again, the
    doubling at 0.001953125). Over hulls of many sizes, each suggestion given back passes."""
    import re

    from gpr_kinematics.workspace.voxels import grid
    for size in np.linspace(0.2, 3.0, 57):
        hull = np.array([[0.0, size], [0.0, 1.1 * size], [0.0, 2.0 * size]])
        with pytest.raises(InputError) as info:
            grid(hull, np.full(3, 1e-3), 1e-3)
        suggested = float(re.search(r'; (?:about )?([\d.e+-]+) or more\)$', str(info.value)).group(1))
        grid(hull, np.full(3, suggested), suggested)
