"""Where the covering runs: one process and a Dask local cluster give the same boxes in the same order; the
parts of a run only change the order; bad schedulers are refused with what is allowed."""
import numpy as np
import pytest
from gpr_kinematics.errors import InputError
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.workspace import approximate, load_workspace_model
from gpr_kinematics.workspace import scheduler as sched
from gpr_kinematics.workspace.scheduler import Executor

pytest.importorskip('distributed')


@pytest.fixture(scope='module')
def cluster():
    with Executor('local', 2) as ex:
        yield ex


def _same(a, b):
    return (np.array_equal(a.inner, b.inner) and np.array_equal(a.boundary, b.boundary)
            and a.outside_boxes == b.outside_boxes and a.evaluations == b.evaluations)


@pytest.mark.parametrize('name, delta, chunk', [('dextar_6d', 0.02, 1024), ('tripod_3rps', 0.004, 4096)])
def test_a_local_cluster_gives_exactly_the_boxes_of_one_process(cluster, name, delta, chunk):
    model = load_workspace_model(config_path(f'mechanisms/{name}.yaml'))
    one = approximate(model, delta, chunk_size=chunk)
    many = approximate(model, delta, chunk_size=chunk, scheduler=cluster)
    assert many.extra['cluster_used'] and many.extra['workers'] == 2 and not one.extra['cluster_used']
    assert _same(one, many) and one.inner_boxes > 0 and one.boundary_boxes > 0


def _sorted(boxes):
    flat = boxes.reshape(boxes.shape[0], -1)
    return flat[np.lexsort(flat.T[::-1])]


def test_the_parts_change_the_order_of_the_boxes_not_the_boxes():
    model = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))
    a = approximate(model, 0.004, chunk_size=1024, parts=1)
    b = approximate(model, 0.004, chunk_size=1024, parts=64)
    c = approximate(model, 0.004, chunk_size=1024, parts=64)
    assert _same(b, c)                                                    # deterministic
    assert not np.array_equal(a.inner, b.inner)                           # another order ...
    assert np.array_equal(_sorted(a.inner), _sorted(b.inner))             # ... of the same boxes
    assert np.array_equal(_sorted(a.boundary), _sorted(b.boundary))


def test_a_time_limit_inside_the_parts_keeps_a_valid_result():
    model = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))
    res = approximate(model, 0.0005, chunk_size=1024, max_seconds=0.3)
    assert res.interrupted and res.stopped.startswith('time limit')
    rng = np.random.default_rng(4)
    pts = model.box[:, 0] + (model.box[:, 1] - model.box[:, 0]) * rng.random((30000, 3))
    ok = model.feasible(pts)
    from gpr_kinematics.workspace import contains_points
    assert np.all(contains_points(np.concatenate([res.inner, res.boundary]), pts[ok]))
    assert not np.any(contains_points(res.inner, pts[~ok]))


@pytest.mark.parametrize('scheduler, workers, match', [
    ('cluster', None, "scheduler 'cluster' is not allowed; allowed: none, local or a Dask scheduler address"),
    ('tcp://host', None, 'not allowed'),
    ('http://host:8786', None, 'not allowed'),
    ('tcp://host:8786; rm -rf', None, 'not allowed'),
    ('local', 0, 'workers must be an integer from 1 to 256'),
    ('local', 1000, 'workers must be an integer from 1 to 256'),
    ('none', 2, 'workers applies to --scheduler local only'),
])
def test_bad_schedulers_are_refused(scheduler, workers, match):
    with pytest.raises(InputError, match=match):
        Executor(scheduler, workers)


def test_an_unreachable_scheduler_is_reported(monkeypatch):
    import socket
    s = socket.socket()
    s.bind(('127.0.0.1', 0))
    port = s.getsockname()[1]
    s.close()                                                   # a port nobody listens on
    monkeypatch.setattr(sched, 'CONNECT_TIMEOUT', 2.0)
    model = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))
    with pytest.raises(InputError, match=f'cannot connect to the Dask scheduler at tcp://127.0.0.1:{port}'):
        approximate(model, 0.004, chunk_size=1024, scheduler=f'tcp://127.0.0.1:{port}')
