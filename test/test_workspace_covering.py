"""Nonuniform covering and grid methods: inner boxes are feasible, feasible points lie in the outer
approximation, volumes converge (closed-form mechanisms), interruption keeps a valid result."""
import io
import math
import warnings

import numpy as np
import pytest
from gpr_kinematics.errors import InputError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.workspace import approximate, box_volume, contains_points
from gpr_kinematics.workspace.loader import load_workspace_model
from gpr_kinematics.workspace.shell_arm import ShellArmModel

RNG = np.random.default_rng(2024)
CASES = [('tripod_3rps', 0.004), ('upu3', 0.01), ('gpr', 0.004), ('rrr3_planar', 0.004), ('dextar', 0.01),
         ('shell_arm', 0.02)]


def _points_in_boxes(boxes, n):
    idx = RNG.integers(0, boxes.shape[0], n)
    b = boxes[idx]
    return b[:, :, 0] + (b[:, :, 1] - b[:, :, 0]) * RNG.random(b.shape[:2])


@pytest.fixture(scope='module', params=CASES, ids=[c[0] for c in CASES])
def covered(request):
    name, delta = request.param
    model = load_workspace_model(config_path(f'mechanisms/{name}.yaml'))
    return model, approximate(model, delta)


def test_random_points_of_inner_boxes_satisfy_every_constraint(covered):
    model, res = covered
    assert res.inner_boxes > 0 and res.certified and not res.interrupted
    pts = _points_in_boxes(res.inner, 20000)
    g = model.evaluate(pts)
    assert np.all((g >= model.lower) & (g <= model.upper))
    # also the corners (the extreme points of the boxes)
    corners = np.stack([res.inner[:, :, 0], res.inner[:, :, 1]], axis=1).reshape(-1, len(model.variables))
    assert np.all(model.feasible(corners))


def test_feasible_sample_points_lie_in_the_outer_approximation(covered):
    model, res = covered
    pts = model.box[:, 0] + (model.box[:, 1] - model.box[:, 0]) * RNG.random((60000, len(model.variables)))
    ok = model.feasible(pts)
    assert ok.sum() > 50
    outer = np.concatenate([res.inner, res.boundary])
    assert np.all(contains_points(outer, pts[ok]))
    # and infeasible points are never inside inner boxes
    assert not np.any(contains_points(res.inner, pts[~ok]))


def test_boxes_are_disjoint_in_volume_and_below_delta(covered):
    model, res = covered
    total = box_volume(np.concatenate([res.inner, res.boundary]))
    assert math.isclose(total, res.outer_volume, rel_tol=1e-12)
    assert res.outer_volume <= np.prod(model.box[:, 1] - model.box[:, 0]) * (1 + 1e-12)
    diam = np.max((res.boundary[:, :, 1] - res.boundary[:, :, 0]) * model.scale, axis=1)
    assert np.all(diam < res.delta)
    # Monte-Carlo volume of the workspace lies between the inner and outer volumes
    n = 100_000
    pts = model.box[:, 0] + (model.box[:, 1] - model.box[:, 0]) * RNG.random((n, len(model.variables)))
    frac = model.feasible(pts).mean()
    vol = np.prod(model.box[:, 1] - model.box[:, 0])
    sigma = vol * math.sqrt(frac * (1 - frac) / n)
    assert res.inner_volume - 5 * sigma <= frac * vol <= res.outer_volume + 5 * sigma


def test_closed_form_shell_volume_is_bracketed_and_converges():
    model = load_workspace_model(config_path('mechanisms/shell_arm.yaml'))
    exact = model.exact_volume()
    gaps = []
    for delta in (0.08, 0.04, 0.02, 0.01):
        res = approximate(model, delta)
        assert res.inner_volume <= exact <= res.outer_volume
        gaps.append(res.outer_volume - res.inner_volume)
    # the boundary layer is a surface times delta: halving delta about halves the gap
    ratios = np.array(gaps[1:]) / np.array(gaps[:-1])
    assert np.all(ratios < 0.65) and np.all(ratios > 0.35)
    assert gaps[-1] < 0.1 * exact


def test_closed_form_dextar_area_is_bracketed_and_converges():
    model = load_workspace_model(config_path('mechanisms/dextar.yaml'))
    exact = model.exact_area()
    prev = None
    for delta in (0.02, 0.005, 0.00125):
        res = approximate(model, delta)
        assert res.inner_volume <= exact <= res.outer_volume
        if prev is not None:
            assert res.inner_volume >= prev.inner_volume and res.outer_volume <= prev.outer_volume
        prev = res
    assert (prev.outer_volume - prev.inner_volume) / exact < 0.02


def test_tripod_volumes_converge_as_delta_shrinks():
    model = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))
    results = [approximate(model, d) for d in (0.016, 0.008, 0.004)]
    inner = [r.inner_volume for r in results]
    outer = [r.outer_volume for r in results]
    assert inner[0] <= inner[1] <= inner[2] <= outer[2] <= outer[1] <= outer[0]
    assert (outer[2] - inner[2]) < 0.7 * (outer[1] - inner[1])


@pytest.mark.parametrize('method', ['grid', 'uniform'])
def test_grid_methods_agree_with_the_certified_covering(method):
    model = ShellArmModel(0.3, 0.2, floor=-0.1)
    res = approximate(model, 0.02, method=method)
    assert not res.certified
    exact = model.exact_volume()
    assert abs(res.inner_volume - exact) / exact < 0.2
    assert res.inner_volume <= exact * 1.01 and res.outer_volume >= exact * 0.99
    # node-sampled inner boxes are feasible at their sample nodes (corners)
    corners = np.concatenate([res.inner[:, :, 0], res.inner[:, :, 1]])
    assert np.all(model.feasible(corners))


def test_interruption_keeps_a_valid_partial_result():
    model = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))

    class Interrupting(type(model)):
        calls = 0

        def enclose(self, x):
            Interrupting.calls += 1
            if Interrupting.calls == 18:
                raise KeyboardInterrupt
            return super().enclose(x)

    m = Interrupting(model.R, model.r, model.leg_min, model.leg_max, box=model.box)
    res = approximate(m, 0.002)
    assert res.interrupted and res.stopped == 'interrupted' and res.levels <= 18 and res.inner_boxes > 0
    pts = model.box[:, 0] + (model.box[:, 1] - model.box[:, 0]) * RNG.random((30000, 3))
    ok = model.feasible(pts)
    assert np.all(contains_points(np.concatenate([res.inner, res.boundary]), pts[ok]))
    assert np.all(model.feasible(_points_in_boxes(res.inner, 5000)))
    # a time limit acts the same way
    res2 = approximate(model, 0.0005, max_seconds=0.05)
    assert res2.interrupted
    assert np.all(contains_points(np.concatenate([res2.inner, res2.boundary]), pts[ok]))


@pytest.mark.parametrize('limit', [30000, 100000])
def test_the_box_limit_bounds_the_boxes_of_a_run_cut_into_parts(limit):
    """Once a run is cut into parts, each part had the whole limit as its own: at 0.5 mm the tripod came back with
    804,787 boxes for max_boxes = 100,000 (16 parts, each stopping near the limit with its pending boxes kept as
    boundary boxes). The parts' budgets now add up to the limit, and the result stays a valid outer approximation."""
    model = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))
    res = approximate(model, 0.0005, max_boxes=limit)
    # before the run is cut into parts (30,000), or once its parts used their shares (100,000)
    assert res.stopped == f'box limit ({limit} boxes{", shared among the parts" if limit > 30000 else ""})'
    assert res.inner_boxes + res.boundary_boxes <= limit
    pts = model.box[:, 0] + (model.box[:, 1] - model.box[:, 0]) * RNG.random((20000, 3))
    assert np.all(contains_points(np.concatenate([res.inner, res.boundary]), pts[model.feasible(pts)]))
    assert np.all(model.feasible(_points_in_boxes(res.inner, 2000)))


def test_progress_bar_is_written_for_long_runs():
    model = load_workspace_model(config_path('mechanisms/shell_arm.yaml'))
    stream = io.StringIO()
    res = approximate(model, 0.05, progress=True, progress_stream=stream, progress_after=0.0)   # show at once
    text = stream.getvalue()
    assert '% of volume decided' in text and text.endswith('\n')
    assert '\r' not in text    # not a terminal: plain lines (test_progress_off_a_terminal_is_plain_throttled_lines)
    last = text.rstrip('\n').split('\n')[-1]
    # the last update: everything decided, the last level, all boxes processed, the final volumes
    assert last.startswith('100.0% of volume decided')
    assert f'level {res.levels},' in last and f'{res.evaluations:,} boxes processed' in last
    assert f'inner {res.inner_volume:.4g}, boundary {res.outer_volume - res.inner_volume:.4g} m*m*m' in last


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def _feed(bar, times, fracs):
    """Updates of ``bar`` at the clock's ``times`` [s] with the decided shares ``fracs``."""
    for t, f in zip(times, fracs, strict=True):
        bar.clock = lambda t=t: t
        bar.update(3, 0.01, 0.006, int(1000 * t), 0.25, 0.05, f)
    bar.close()


def test_progress_off_a_terminal_is_plain_throttled_lines():
    """Into a file or a pipe (a log) the bar writes no carriage-return redraws: a plain line once the run has lasted
    ``after`` s, then at most one every ``every`` s, and one line when the whole volume is decided, as ``gpr program
    check``'s progress does (docs/workspace.md); on a terminal it is redrawn in place at every update."""
    from gpr_kinematics.workspace.progress import Progress
    times = [0.5 * k for k in range(1, 61)]             # an update every 0.5 s for 30 s: 60 updates
    fracs = [min(t / 30.0, 1.0) for t in times]
    stream = io.StringIO()
    bar = Progress(True, stream, after=2.0, units='m*m', clock=lambda: 0.0)
    _feed(bar, times, fracs)
    lines = stream.getvalue().splitlines()
    assert '\r' not in stream.getvalue() and stream.getvalue().endswith('\n')
    assert [float(ln.split()[-2]) for ln in lines] == [2.0, 7.0, 12.0, 17.0, 22.0, 27.0, 30.0]
    assert lines[0].startswith('  6.7% of volume decided | level 3, diameter 10 mm (delta 6 mm) | 2,000 boxes')
    assert lines[-1].startswith('100.0% of volume decided') and lines[-1].endswith('m*m | 30.0 s')
    # the last numbers shown again (refresh) after the end: no second final line
    bar.refresh()
    assert stream.getvalue().splitlines() == lines
    # on a terminal: every update redrawn in place after 2 s, the line ended at the close
    tty = _Terminal()
    _feed(Progress(True, tty, after=2.0, units='m*m', clock=lambda: 0.0), times, fracs)
    text = tty.getvalue()
    assert text.count('\r') == 57 and text.endswith('\n') and text.count('\n') == 1
    assert text.split('\r')[-1].startswith('[########################] 100.0% of volume decided')


def test_the_last_line_off_a_terminal_is_written_where_the_sum_stops_an_ulp_short():
    """The decided volume, a float sum, ended at 0.9999999999999999 of the box: the line of the whole volume was
    never written into a log (the last one read 99.1 %). The close writes the last numbers where they were not."""
    from gpr_kinematics.workspace.progress import Progress
    times = [0.5 * k for k in range(1, 61)]
    fracs = [min(t / 30.0, 1.0 - 2.0 ** -53) for t in times]
    stream = io.StringIO()
    _feed(Progress(True, stream, after=2.0, units='m*m', clock=lambda: 0.0), times, fracs)
    lines = stream.getvalue().splitlines()
    assert [float(ln.split()[-2]) for ln in lines] == [2.0, 7.0, 12.0, 17.0, 22.0, 27.0, 30.0]
    assert lines[-1].startswith('100.0% of volume decided') and lines[-1].endswith('| 30.0 s')
    stream = io.StringIO()   # closed right after a written line: nothing written twice
    _feed(Progress(True, stream, after=2.0, units='m*m', clock=lambda: 0.0), times[:14], fracs[:14])
    assert [float(ln.split()[-2]) for ln in stream.getvalue().splitlines()] == [2.0, 7.0]


@pytest.mark.parametrize('kwargs, match', [
    ({'delta': 0.0}, 'positive'), ({'delta': -1.0}, 'positive'), ({'delta': float('nan')}, 'positive'),
    ({'delta': 1e-20}, 'too small'), ({'delta': 0.1, 'method': 'sivia'}, 'unknown workspace method'),
    ({'delta': 0.1, 'box': [[0, 1]]}, 'shape'), ({'delta': 0.1, 'box': [[0, 1], [0, 1], [2, 1]]}, 'lower < upper'),
    ({'delta': 0.1, 'parts': True}, 'parts must be an integer'), ({'delta': 0.1, 'parts': 2.0}, 'parts must be'),
    ({'delta': 0.1, 'chunk_size': np.True_}, 'chunk_size must be'), ({'delta': 0.1, 'chunk_size': 0}, 'chunk_size'),
])
def test_bad_arguments_raise_input_errors(kwargs, match):
    with pytest.raises(InputError, match=match):
        approximate(ShellArmModel(), **kwargs)


def test_numpy_counts_are_taken_as_the_same_python_ints():
    # printed as numbers in the refusals, so taken: a numpy int from a config array ran as its Python int does
    a = approximate(ShellArmModel(), 0.05, chunk_size=np.int64(64), parts=np.int32(2))
    b = approximate(ShellArmModel(), 0.05, chunk_size=64, parts=2)
    assert np.array_equal(a.inner, b.inner) and np.array_equal(a.boundary, b.boundary) and a.inner.size > 0


def test_contains_points_matches_brute_force():
    lo = RNG.random((2000, 3))
    boxes = np.stack([lo, lo + 0.1 * RNG.random((2000, 3))], axis=2)
    pts = np.concatenate([RNG.random((5000, 3)) * 1.2 - 0.1, boxes[:, :, 0], boxes[:, :, 1]])
    brute = np.array([np.any(np.all((boxes[:, :, 0] <= p) & (p <= boxes[:, :, 1]), axis=1)) for p in pts])
    assert np.array_equal(contains_points(boxes, pts), brute)
    assert brute[5000:].all() and 0 < brute[:5000].sum() < 5000


@pytest.mark.parametrize('points, shown', [('abc', "'abc' (not numbers)"), ([[0.1, 0.2]], 'of shape (1, 2)'),
                                           ([['0.1', '0.2', '0.3']], "[['0.1', '0.2', '0.3']] (not numbers)")])
def test_contains_points_names_points_that_are_no_numbers_as_a_bad_shape(points, shown):
    """contains_points(boxes, 'abc') raised numpy's ValueError (could not convert string to float)."""
    boxes = np.zeros((4, 3, 2))
    with pytest.raises(InputError) as err:
        contains_points(boxes, points)
    assert str(err.value) == (f'boxes of shape (4, 3, 2) and points {shown}; allowed: boxes (n, d, 2) and points '
                              '(N, d) of the same d')


def test_contains_points_of_large_overlapping_boxes_stays_bounded(monkeypatch):
    """3,000 boxes each over most of the hull: the first grid (29 cells a side) would register each box in about
    20,000 cells (60 million registrations, about 2 GB of index arrays); the grid is made coarser until it holds at
    most MAX_REGISTRATIONS, and the points run in bounded batches of candidate pairs (forced small here): the same
    answer as brute force, with a bounded peak of memory."""
    import tracemalloc

    from gpr_kinematics.workspace import boxes as boxes_module
    rng = np.random.default_rng(7)
    lo = rng.random((3000, 3)) * 0.1
    boxes = np.stack([lo, 0.9 + rng.random((3000, 3)) * 0.1], axis=2)
    pts = rng.random((400, 3)) * 1.2 - 0.1
    brute = np.array([np.any(np.all((boxes[:, :, 0] <= p) & (p <= boxes[:, :, 1]), axis=1)) for p in pts])
    tracemalloc.start()
    try:
        got = contains_points(boxes, pts)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert np.array_equal(got, brute) and 0 < brute.sum() < len(pts)
    assert peak < 400e6, peak
    monkeypatch.setattr(boxes_module, 'MAX_PAIRS', 1000)             # runs of about one point each
    assert np.array_equal(contains_points(boxes, pts), brute)


def test_upu3_workspace_shrinks_with_the_base_and_grows_with_the_limb_limit():
    """Aboulissane and El Bakkali, "Modeling and Simulation of Spatial Mechanism" (2015), Figs. 8-9: a larger base
    shrinks the workspace, a longer limb limit enlarges the upper dome. Certified: the outer volume of one is
    below the inner volume of the other."""
    def run(**over):
        model = load_workspace_model(config_path('mechanisms/upu3.yaml'), over)
        model.box = np.array([[-0.4, 0.4], [-0.4, 0.4], [0.0, 0.4]])
        return approximate(model, 0.01)

    base = run()
    wide = run(b=0.25)
    tall = run(limb_max=0.3)
    assert wide.outer_volume < base.inner_volume
    assert base.outer_volume < tall.inner_volume
    top = lambda r: np.concatenate([r.inner, r.boundary])[:, 2, 1].max()  # noqa: E731
    assert top(tall) > top(base) + 0.02


@pytest.mark.slow
@pytest.mark.parametrize('method', ['covering', 'grid', 'uniform'])
def test_every_method_has_a_default_time_limit(monkeypatch, method):
    """Issue 18: the grid method at 0.072 mm on the planar 3-RRR ran without end; without a limit of the caller's,
    every method stops at base.DEFAULT_MAX_SECONDS (600 s; here made 0.05 s) with a valid, interrupted result: the
    unexamined boxes (the uniform grid's cells with a corner not evaluated) are boundary boxes."""
    from gpr_kinematics.workspace import base
    from gpr_kinematics.workspace import grid as grid_module
    monkeypatch.setattr(base, 'DEFAULT_MAX_SECONDS', 0.05)
    monkeypatch.setattr(grid_module, '_POINT_CHUNK', 2000)   # the uniform grid looks at the clock per chunk
    model = load_workspace_model(config_path('mechanisms/rrr3_planar.yaml'))
    delta = 0.002 if method == 'uniform' else 0.000072
    res = approximate(model, delta, method=method)
    assert res.interrupted and res.stopped == 'time limit (0.05 s)' and res.seconds < 30, (res.stopped, res.seconds)
    pts = model.box[:, 0] + (model.box[:, 1] - model.box[:, 0]) * RNG.random((20000, 3))
    ok = model.feasible(pts)
    assert np.all(contains_points(np.concatenate([res.inner, res.boundary]), pts[ok]))
    if res.inner_boxes:
        assert np.all(model.feasible(_points_in_boxes(res.inner, 2000)))


@pytest.mark.parametrize('value', [0, -1, float('nan'), float('inf'), 1e9, True])
def test_time_limits_are_bounded(value):
    model = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))
    with pytest.raises(InputError, match='max_seconds = .*; allowed: a time limit in seconds, > 0 and at most 604800'):
        approximate(model, 0.05, max_seconds=value)


def test_options_that_are_not_numbers_are_named():
    """delta='a' and grid_nodes='a' or 2.5 were TypeErrors, a 400-digit bound an OverflowError."""
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.workspace import approximate, load_workspace_model

    model = load_workspace_model(config_path('mechanisms/shell_arm.yaml'))
    for kwargs, words in (({'delta': 'a'}, r"delta must be a positive length in metres, got 'a'"),
                          ({'delta': 0.1, 'method': 'grid', 'grid_nodes': 'a'}, r"nodes per edge = 'a'; allowed"),
                          ({'delta': 0.1, 'method': 'grid', 'grid_nodes': 2.5}, r'nodes per edge = 2.5; allowed'),
                          ({'delta': 0.1, 'box': [[0, 10 ** 400]] * 3}, r'initial box must be numbers')):
        with pytest.raises(InputError, match=words):
            approximate(model, **kwargs)


@pytest.mark.parametrize('model', ['upu3.yaml', None])
def test_a_model_that_is_no_model_is_named(model):
    """approximate('upu3.yaml', 0.01) raised AttributeError ('str' object has no attribute 'variables')."""
    with pytest.raises(InputError) as err:
        approximate(model, 0.01)
    assert str(err.value) == (f'model = {model!r}; allowed: a WorkspaceModel (or an equation model), as '
                              'load_workspace_model(path) returns it')


def _ball(n: int) -> dict:
    """The unit ball of ``n`` variables, all of them outputs, as an equation model's YAML mapping."""
    names = [f'x{i}' for i in range(n)]
    return {'type': 'equations', 'name': f'ball{n}', 'variables': {v: [-1.0, 1.0] for v in names},
            'outputs': names, 'inequalities': [' + '.join(f'{v}^2' for v in names) + ' <= 1']}


def test_the_default_box_limit_bounds_the_boxes_bytes_not_their_count(monkeypatch):
    """--max-boxes counted boxes: 10 million boxes of 16 variables (256 bytes each, not 48) took 4.3 GB at delta
    0.2, where the docs said 0.5 GB. The default limit is now the boxes BOX_MEMORY (0.48 GB) holds, 16 bytes per
    variable, at most MAX_BOXES: unchanged up to 3 variables, 5 million for DexTAR 6-D, 1,875,000 for 16."""
    from gpr_kinematics.workspace import base, default_max_boxes
    from gpr_kinematics.workspace.loader import model_from_mapping
    ball16, ball3 = model_from_mapping(_ball(16)), model_from_mapping(_ball(3))
    assert base.BOX_MEMORY == 480_000_000 and base.box_bytes(ball16) == 256 and base.box_bytes(ball3) == 48
    assert default_max_boxes(ball16) == 1_875_000 and default_max_boxes(ball3) == 10_000_000
    names = ('tripod_3rps', 'dextar', 'gpr', 'dextar_6d')
    limits = [default_max_boxes(load_workspace_model(config_path(f'mechanisms/{name}.yaml'))) for name in names]
    assert limits == [10_000_000, 10_000_000, 10_000_000, 5_000_000]
    # the run takes its limit from its model: with 25,600 bytes for the boxes, 100 of 16 variables, 533 of 3
    monkeypatch.setattr(base, 'BOX_MEMORY', 25_600)
    res16, res3 = approximate(ball16, 1e-4), approximate(ball3, 1e-4)
    assert (res16.stopped, res3.stopped) == ('box limit (100 boxes)', 'box limit (533 boxes)')
    assert res16.inner_boxes + res16.boundary_boxes <= 100 and res3.inner_boxes + res3.boundary_boxes <= 533
    assert approximate(ball16, 1e-4, max_boxes=300).stopped == 'box limit (300 boxes)'   # a limit given is kept


def _memory(monkeypatch, pages, container=None, folder=None):
    """The machine's physical memory as ``pages`` of 4096 bytes (``None``: sysconf does not give it), and a
    container's limit ``container`` (a cgroup file's text written in ``folder``; None: no container)."""
    from gpr_kinematics.workspace import base

    limits: tuple[str, ...] = ()
    if container is not None:
        (folder / 'memory.max').write_text(container)
        limits = (str(folder / 'absent.max'), str(folder / 'memory.max'))
    monkeypatch.setattr(base, 'CGROUP_LIMITS', limits)

    def sysconf(name):
        if pages is None:
            raise ValueError(f'unrecognized configuration name {name!r}')
        return {'SC_PAGE_SIZE': 4096, 'SC_PHYS_PAGES': pages}[name]
    monkeypatch.setattr(base.os, 'sysconf', sysconf)


def test_a_box_limit_given_is_bounded_by_the_machines_memory(monkeypatch):
    """max_boxes given was only checked to be positive: 1e9 boxes of 16 variables (256 GB) were taken as asked.
    A limit whose boxes take more than a quarter of the physical memory is refused, naming the count, the bytes and
    the most for the model (here a machine of 1.024 GB: 256 MB of boxes, 1,000,000 of 16 variables, 5,333,333 of 3),
    and the default never exceeds it; where sysconf gives nothing, the default's BOX_MEMORY is the bound."""
    from gpr_kinematics.workspace import base, default_max_boxes
    from gpr_kinematics.workspace.loader import model_from_mapping
    ball16, ball3 = model_from_mapping(_ball(16)), model_from_mapping(_ball(3))
    _memory(monkeypatch, 250_000)
    assert base.physical_memory() == 1_024_000_000 and base.box_memory_limit() == 256_000_000
    assert (base.most_boxes(ball16), base.most_boxes(ball3)) == (1_000_000, 5_333_333)
    assert (default_max_boxes(ball16), default_max_boxes(ball3)) == (1_000_000, 5_333_333)
    with pytest.raises(InputError) as err:
        approximate(ball16, 0.5, max_boxes=10**9)
    assert str(err.value) == ('max_boxes = 1000000000: that many boxes of 16 variables (256 bytes each) take 256 GB; '
                              'allowed: at most 1000000 boxes for this model (0.256 GB, 25% of the 1.02 GB of '
                              'physical memory)')
    with pytest.raises(InputError, match='max_boxes = 1000001: .* take 0.256 GB; allowed: at most 1000000 boxes'):
        approximate(ball16, 0.5, max_boxes=1_000_001)
    with pytest.raises(InputError, match='max_boxes = <an integer of about 401 digits>: .* take <an integer of about '
                                         '403 digits> bytes; '):
        approximate(ball16, 0.5, max_boxes=10**400)
    res = approximate(ball3, 0.5, max_boxes=5_333_333)      # the most is allowed
    assert not res.interrupted and res.inner_boxes == 64
    for bad in (0, -1, True, 2.5, '10'):
        with pytest.raises(InputError, match='allowed: a whole number of boxes, at least 1'):
            approximate(ball3, 0.5, max_boxes=bad)
    _memory(monkeypatch, None)
    assert base.physical_memory() is None and base.most_boxes(ball16) == default_max_boxes(ball16) == 1_875_000
    with pytest.raises(InputError) as err:
        approximate(ball16, 0.5, max_boxes=1_875_001)
    assert str(err.value).endswith("allowed: at most 1875000 boxes for this model (0.48 GB, the default limit's "
                                   'memory: this system does not give its physical memory)')


def test_the_uniform_grid_limit_is_of_bytes_too():
    """The uniform grid refused beyond 10 million cells whatever their variables; for 4 variables (64 bytes a cell)
    it is 7.5 million."""
    model = ShellArmModel()
    model.variables, model.units, model.scale = ('x', 'y', 'z', 'w'), ('m',) * 4, np.ones(4)
    box = np.array([[0.0, 1.0]] * 4)
    with pytest.raises(InputError, match=r'uniform grid with \[53, 53, 53, 53\] cells \(7\.89e\+06\) is too large for '
                                         r'delta 0\.019; allowed: at most 7\.5e\+06 cells'):
        approximate(model, 0.019, method='uniform', box=box)


def test_a_containers_memory_limit_bounds_the_boxes(monkeypatch, tmp_path):
    """The physical memory was the bound also in a container whose limit is lower (the process is killed at the
    limit): the smaller of the two counts, and the message says which; 'max' (no limit) leaves the machine's."""
    from gpr_kinematics.workspace import base
    from gpr_kinematics.workspace.loader import model_from_mapping
    ball16 = model_from_mapping(_ball(16))
    _memory(monkeypatch, 2_500_000, '512000000\n', tmp_path)              # 10.24 GB machine, 0.512 GB container
    assert base.usable_memory()[0] == 512_000_000 and base.most_boxes(ball16) == 500_000
    with pytest.raises(InputError) as err:
        approximate(ball16, 0.5, max_boxes=500_001)
    assert str(err.value).endswith("allowed: at most 500000 boxes for this model (0.128 GB, 25% of the 0.512 GB of "
                                   "the container's memory limit)")
    _memory(monkeypatch, 2_500_000, 'max\n', tmp_path)
    assert base.usable_memory() == (10_240_000_000, 'the 10.2 GB of physical memory')
    _memory(monkeypatch, None, '512000000', tmp_path)
    assert base.usable_memory()[0] == 512_000_000


def test_contains_points_down_to_a_single_cell(monkeypatch):
    """A registration limit below the box count coarsens the bucket grid down to one cell holding every box (and
    no further): still the brute-force answer, closed boxes included (their corners are in)."""
    from gpr_kinematics.workspace import boxes as boxes_module
    rng = np.random.default_rng(3)
    lo = rng.random((40, 2))
    boxes = np.stack([lo, lo + 0.2 * rng.random((40, 2))], axis=2)
    pts = np.concatenate([rng.random((500, 2)) * 1.4 - 0.2, boxes[:, :, 0], boxes[:, :, 1]])
    brute = np.array([np.any(np.all((boxes[:, :, 0] <= p) & (p <= boxes[:, :, 1]), axis=1)) for p in pts])
    for limit in (1, 39, 200):
        monkeypatch.setattr(boxes_module, 'MAX_REGISTRATIONS', limit)
        with warnings.catch_warnings():
            warnings.simplefilter('error')                      # no division by a grid of 0 cells on the way
            assert np.array_equal(contains_points(boxes, pts), brute), limit
    assert brute[500:].all() and 0 < brute[:500].sum() < 500


def test_touches_sees_every_face_of_the_initial_box():
    """``touches`` is true when a box reaches a lower or an upper face of the initial box along any axis (closed:
    equal bounds count), false for boxes strictly inside, and for no boxes at all."""
    from gpr_kinematics.workspace.boxes import touches
    box = np.array([[0.0, 1.0], [-2.0, 2.0]])
    inside = np.array([[[0.2, 0.8], [-1.0, 1.0]]])
    assert not touches(box, inside) and not touches(box, np.empty((0, 2, 2)))
    for axis in range(2):
        for side in range(2):
            b = inside.copy()
            b[0, axis, side] = box[axis, side]
            assert touches(box, inside, b) and touches(box, b, np.empty((0, 2, 2))), (axis, side)


def test_a_delta_below_the_float_spacing_of_the_bounds_is_refused():
    """A box of three consecutive floats in x at 0.5 m (the shell's outer sphere runs through it) cannot be halved
    below an ulp: ``delta`` 1e-27 m passed the rule of 2^-40 of the diameter (1.7e-16 m) and the covering bisected
    without end (125,646 boundary boxes after its 30 s time limit). 2^-40 of the largest scaled bound is the rule now;
    at that delta every edge at least delta long halves into two strictly shorter ones (checked on the floats)."""
    box = np.array([[0.49999999999999994, 0.5000000000000001], [0.0, 1e-30], [0.0, 1e-30]])
    with pytest.raises(InputError, match=r'too small for the initial box .*bounds up to 0\.5 m scaled.*'
                                         r'allowed delta >= 4\.55e-13 m \(2\^-40 of its largest scaled bound\)'):
        approximate(ShellArmModel(), 1e-27, box=box, max_seconds=2.0)
    for bound in (0.5, 0.52, 1.0, 3.0e5, 1.0e6):
        delta = bound * 2.0**-40
        lo = np.nextafter(bound, 0.0) - delta * np.arange(1.0, 3.0)   # edges just above delta, ending at bound
        hi = np.full_like(lo, bound)
        mid = 0.5 * (lo + hi)
        assert np.all((hi - lo >= delta) & (lo < mid) & (mid < hi)), bound


def test_an_initial_box_of_volume_underflowing_to_zero_is_refused():
    """Links of 1e-300 m gave the box [-2e-300, 2e-300]^3, of volume 0 in float64: the run divided its progress
    by that volume (ZeroDivisionError). A box whose volume is not a normal float is an InputError naming it (such
    links are refused as lengths since: a box given so)."""
    model = ShellArmModel(box=np.array([[0.0, 1e-110]] * 3))
    assert float(np.prod(model.box[:, 1] - model.box[:, 0])) == 0.0
    with pytest.raises(InputError, match=r'the initial box has volume 0 .*allowed: a box of volume at least '
                                         r'2\.23e-308'):
        approximate(model, 1e-115)
    tiny = ShellArmModel(1e-6, 1e-6)                        # the least links: volume 6.4e-17, covered
    res = approximate(tiny, 1e-7)
    assert 0.0 < res.inner_volume <= tiny.exact_volume() <= res.outer_volume


def test_the_uniform_grid_keeps_to_the_box_limit_given():
    """``max_boxes`` (``--max-boxes``) was ignored by the uniform grid: DexTAR at delta 0.33 mm with a limit of
    1,000 boxes returned 3,158,840 inner and 8,332 boundary cells. Its 3,152 x 3,152 cells are refused now,
    naming the limit; a grid within it runs and keeps at most that many boxes."""
    model = load_workspace_model(config_path('mechanisms/dextar.yaml'))
    with pytest.raises(InputError, match=r'uniform grid with \[3152, 3152\] cells \(9\.94e\+06\) is too large for '
                                         r'delta 0\.00033; allowed: at most 1000 cells \(the box limit, max_boxes'):
        approximate(model, 0.00033, method='uniform', max_boxes=1000)
    res = approximate(model, 0.04, method='uniform', max_boxes=27 * 27)     # 1.04 m / 0.04 m: 26 or 27 cells an edge
    assert res.inner_boxes + res.boundary_boxes <= 27 * 27 and res.inner_boxes > 0 and not res.certified


def test_contains_points_takes_nan_and_infinite_values_quietly():
    """A NaN point, or boxes of infinite bounds, warned of invalid values (the NaN cell index cast to int64, which
    numpy leaves undefined); the answers are those of the closed-box test: a NaN or infinite coordinate lies in no
    box of finite bounds, a finite point lies in a box of infinite bounds around it."""
    import warnings
    boxes = np.array([[[0.0, 1.0], [0.0, 1.0]], [[2.0, 3.0], [0.0, 1.0]]])
    pts = np.array([[np.nan, 0.5], [np.inf, 0.5], [0.5, -np.inf], [0.5, 0.5], [2.5, 1.0], [1.5, 0.5]])
    wide = np.array([[[-np.inf, np.inf], [0.0, 1.0]], [[5.0, 6.0], [0.0, np.inf]]])
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        assert contains_points(boxes, pts).tolist() == [False, False, False, True, True, False]
        assert contains_points(wide, pts).tolist() == [False, True, False, True, True, True]


def test_a_wide_gpr_tilt_box_converges_as_the_default_one():
    """A tilt box of +-0.5 or +-1 rad (the tool allows up to 1.5 rad at its corners; the workspace lies within about
    +-0.1 rad) left its boundary boxes undecided where 6 m >= R (no bound of the displacements): 2.2 million at 2 mm
    for +-1 rad, the outer volume 1.08 m rad^2 against a true 0.0128, and it did not shrink with delta. The largest
    displacement's lower bound there proves them outside: the outer volumes shrink with delta and bracket a Monte
    Carlo estimate of the true volume, and every feasible sample point lies in the outer approximation. The default
    box's covering is as before (its numbers: docs/workspace.md)."""
    from gpr_kinematics.workspace.gpr import GprModel
    default = approximate(GprModel(), 0.004)
    assert (default.inner_boxes, default.boundary_boxes) == (996, 4068)
    rng = np.random.default_rng(3)
    box = np.array([[0.0, 0.508], [-1.0, 1.0], [-1.0, 1.0]])
    points = box[:, 0] + (box[:, 1] - box[:, 0]) * rng.random((400_000, 3))
    model = GprModel(box=box)
    feasible = model.feasible(points)
    truth = feasible.mean() * box_volume(box[None])
    spread = 3.0 * math.sqrt(feasible.mean() / feasible.size) * box_volume(box[None])   # 3 standard errors
    outer = []
    for delta in (0.004, 0.002):
        res = approximate(model, delta)
        assert res.inner_volume <= truth + spread and truth - spread <= res.outer_volume
        assert contains_points(np.concatenate([res.inner, res.boundary]), points[feasible]).all()
        outer.append(res.outer_volume)
    assert outer[1] < outer[0] < 0.03 and outer[1] < 1.5 * truth, (outer, truth)


def test_the_gpr_heights_faces_at_the_stroke_are_no_faces_the_workspace_extends_beyond(capsys):
    """`gpr workspace gpr.yaml` said "the approximation reaches the faces of the initial box (workspace.box) in z; the
    workspace may extend beyond it": z is the mean of the rods, within the stroke, which is the box's z. Those faces
    are closed; a box whose z ends within the stroke has open faces there, and a tilt box the workspace reaches too."""
    from gpr_kinematics.cli.main import main
    from gpr_kinematics.workspace.gpr import GprModel
    assert not approximate(GprModel(), 0.004).touches_initial_box
    inside = GprModel(box=np.array([[0.1, 0.4], [-0.3, 0.3], [-0.3, 0.3]]))
    assert approximate(inside, 0.004).touches_initial_box
    narrow = GprModel(box=np.array([[0.0, 0.508], [-0.05, 0.05], [-0.05, 0.05]]))
    assert approximate(narrow, 0.004).touches_initial_box
    assert main(['workspace', str(config_path('mechanisms/gpr.yaml')), '--delta', '0.004', '--no-progress']) == 0
    assert 'note: the approximation reaches the faces' not in capsys.readouterr().out
    assert main(['workspace', str(config_path('mechanisms/gpr.yaml')), '--delta', '0.004', '--no-progress', '--set',
                 'workspace={box: {z: [0.1, 0.4], tilt_x: [-0.05, 0.05], tilt_y: [-0.3, 0.3]}}']) == 0
    assert 'note: the approximation reaches the faces of the initial box (workspace.box) in z, tilt_x; the ' \
        'workspace may extend beyond it' in capsys.readouterr().out
