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


@pytest.mark.slow
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


@pytest.mark.slow
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
    ('local', 0, 'workers = 0; allowed: an integer from 1 to 256'),
    ('local', 1000, 'workers = 1000; allowed: an integer from 1 to 256'),
    ('none', 2, 'workers = 2 with scheduler none; allowed: workers with scheduler local only'),
])
def test_bad_schedulers_are_refused(scheduler, workers, match):
    with pytest.raises(InputError, match=match):
        Executor(scheduler, workers)


def test_a_numpy_integer_counts_as_its_number_of_workers():
    """np.int64(2) was refused as 'workers must be an integer from 1 to 256, got 2' (its message printed the number
    since numpy scalars are written as numbers): taken, a Python int for Dask."""
    from gpr_kinematics.workspace.scheduler import check_scheduler
    check_scheduler('local', np.int64(2))
    for bad in (np.int64(0), np.bool_(True), 2.0):
        with pytest.raises(InputError, match=r'^workers = .*; allowed: an integer from 1 to 256$'):
            check_scheduler('local', bad)


def test_an_unreachable_scheduler_is_refused_before_any_work(monkeypatch):
    """Issue 18: ``--scheduler tcp://127.0.0.1:1`` (nothing listens) ran a small covering in this process, exited 0
    and reported that scheduler in its JSON; the address is now connected to before any work, at once."""
    import socket
    import time
    s = socket.socket()
    s.bind(('127.0.0.1', 0))
    port = s.getsockname()[1]
    s.close()                                                   # a port nobody listens on
    model = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))
    calls = []
    monkeypatch.setattr(type(model), 'bounds', lambda self, boxes: calls.append(1))  # no work may start
    for address in (f'tcp://127.0.0.1:{port}', 'tcp://127.0.0.1:1'):
        t0 = time.perf_counter()
        with pytest.raises(InputError, match=f'cannot reach the Dask scheduler at {address}: Connection refused; '
                                             'allowed: the address of a running scheduler'):
            approximate(model, 0.05, scheduler=address)   # one chunk: it never needed the cluster before
        assert time.perf_counter() - t0 < 5.0 and not calls


@pytest.mark.slow
def test_a_port_that_is_no_dask_scheduler_is_reported(monkeypatch):
    import socket
    s = socket.socket()
    s.bind(('127.0.0.1', 0))
    s.listen()                                                  # accepts TCP, never speaks Dask
    port = s.getsockname()[1]
    monkeypatch.setattr(sched, 'CONNECT_TIMEOUT', 2.0)
    try:
        with pytest.raises(InputError, match=f'cannot connect to the Dask scheduler at tcp://127.0.0.1:{port}'):
            Executor(f'tcp://127.0.0.1:{port}')
    finally:
        s.close()


def test_an_answer_that_is_not_dask_is_named_not_an_allocation():
    """Garbage from the address made Dask read a frame length of exabytes: the message was 'Unable to allocate
    3.07 EiB'; it now says the answer is not Dask's protocol."""
    def client(address, timeout):
        raise MemoryError('Unable to allocate 3.07 EiB for an array with shape (3539520420625276928,)')

    with pytest.raises(InputError, match=r'at tcp://127.0.0.1:9: its answer is not the Dask protocol \(is it a Dask '
                                         r'scheduler'):   # it failed at once, not "within 10 s"
        sched._remote_client(client, 'tcp://127.0.0.1:9')


@pytest.mark.slow
def test_sigterm_stops_a_run_on_a_local_cluster_and_closes_it(tmp_path):
    """Issue 18: a grid run killed with SIGTERM left its local cluster's 12 semaphores behind (the resource
    tracker's warning); SIGTERM now stops it like Ctrl-C: the proved boxes are kept and the cluster closed."""
    import json
    import signal
    import subprocess
    import sys
    import time
    cmd = [sys.executable, '-m', 'gpr_kinematics.cli.main', 'workspace', 'rrr3_planar.yaml', '--delta', '0.072',
           '--mm', '--method', 'grid', '--scheduler', 'local', '--workers', '2', '--parts', '2', '--no-progress',
           '--json']
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    time.sleep(12)                        # the cluster starts once a level holds 4096 boxes (about 5 s in)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err   # the status of a stopped command, the proved boxes written
    result = json.loads(out)
    # SIGTERM is told as such (it said 'interrupted', as Ctrl-C): `terminated`, as every command stopped by it
    assert result['cluster_used'] and result['workers'] == 2 and result['stopped'] == 'terminated', result
    assert result['interrupted'] and 'leaked' not in err and 'Traceback' not in err and 'terminated after' in err, err


def test_a_run_names_every_reason_its_parts_stopped_for():
    """Parts stop for reasons of their own: the first part's became the run's, so a run that ended on its time
    limit said 'box limit (5000000 boxes)' when one part had used its share, holding far fewer boxes (a user would
    raise --max-boxes, in vain). Now each reason is named once, a part's share as such."""
    from gpr_kinematics.workspace.levels import Outcome

    out = Outcome()
    for reason in ('box limit (5000 boxes, shared among the parts)', 'time limit (10 s)', '', 'time limit (10 s)',
                   'box limit (5000 boxes, shared among the parts)'):
        out.merge(Outcome(stopped=reason), keep_outside=False)
    assert out.stopped == 'box limit (5000 boxes, shared among the parts); time limit (10 s)'
    # a signal's stop first: Ctrl-C read 'box limit (10000000 boxes, shared among the parts); interrupted' at 1.2
    # million boxes, as if the limit had ended the run
    out.stop('interrupted')
    out.merge(Outcome(stopped='interrupted'), keep_outside=False)
    assert out.stopped == 'interrupted; box limit (5000 boxes, shared among the parts); time limit (10 s)'
    model = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))
    res = approximate(model, 0.0005, chunk_size=1024, parts=8, max_boxes=4000, max_seconds=60)
    assert res.interrupted and res.stopped == 'box limit (4000 boxes, shared among the parts)', res.stopped
    assert res.inner_boxes + res.boundary_boxes <= 4000


def test_a_local_clusters_workers_keep_their_error_logs_to_themselves(capfd):
    """A worker's heartbeat in flight as the cluster closed logged an ERROR with a traceback, which a SIGTERM'd run
    printed to its user (a fresh-clone run failed on it): the workers' logs below CRITICAL stay silent, while a
    task's error still reaches the client as its exception."""
    import logging

    with Executor('local', 1) as ex:
        client = ex._connect()
        client.run(lambda: logging.getLogger('distributed.worker').error('Failed to communicate with scheduler'))

        def fails() -> None:
            raise ValueError('a task that fails')

        with pytest.raises(ValueError, match='a task that fails'):
            client.submit(fails).result()
    assert 'Failed to communicate with scheduler' not in capfd.readouterr().err


def test_a_local_clusters_worker_processes_ignore_sigint():
    """A terminal's Ctrl-C reaches the whole process group: the workers, spawned with Python's SIGINT handler, died
    as the cluster started ("Nanny failed to start", exit 1) or printed 65 lines of KeyboardInterrupt tracebacks
    during a run. They are forked now by a server started with SIGINT ignored: a SIGINT to one does nothing (exit 0;
    it raised KeyboardInterrupt, exit 1), and this process keeps its own handler."""
    import signal

    from distributed.utils import get_mp_context
    before = signal.getsignal(signal.SIGINT)
    sched.start_workers_ignoring_sigint()
    assert signal.getsignal(signal.SIGINT) is before
    child = get_mp_context().Process(target=signal.raise_signal, args=(signal.SIGINT,))
    child.start()
    child.join(60)
    assert child.exitcode == 0


@pytest.mark.parametrize('at', [1, 2])
def test_a_ctrl_c_as_the_clusters_first_processes_start_is_not_lost(at):
    """A Ctrl-C right after the resource tracker (``at`` 1) or the fork server (2) was spawned was lost: SIGINT was
    ignored process-wide while the server started, and the tracker's start unblocked it in this thread meanwhile (the
    command went on to its box limit, exit 0, in a CI run). It now reaches this process's handler."""
    import subprocess
    import sys
    pytest.importorskip('distributed')
    script = f"""
import os, signal, multiprocessing.util as util
from gpr_kinematics.workspace.scheduler import start_workers_ignoring_sigint
spawn, spawned = util.spawnv_passfds, []
def spawn_then_ctrl_c(*args):
    pid = spawn(*args)
    spawned.append(pid)
    if len(spawned) == {at}:
        os.kill(os.getpid(), signal.SIGINT)
    return pid
util.spawnv_passfds = spawn_then_ctrl_c
try:
    start_workers_ignoring_sigint()
    import time
    time.sleep(0.5)
except KeyboardInterrupt:
    print('interrupted', len(spawned))
else:
    print('lost', len(spawned))
"""
    done = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True, timeout=120)
    assert done.stdout.split() == ['interrupted', str(at)], done.stdout + done.stderr


def test_a_signal_while_the_local_cluster_starts_stops_the_run_cleanly(monkeypatch):
    """SIGTERM to the process group as the cluster started killed its workers too: the start's RuntimeError "Nanny
    failed to start." ended the command in a traceback. A start that fails once a signal was caught is the run's
    stop: nothing run on the cluster, the boxes kept, marked interrupted; without a signal the error is raised."""
    import signal

    import distributed
    from gpr_kinematics.workspace.progress import StopFlag

    class FailingCluster:
        kill = True

        def __init__(self, **kwargs):
            if FailingCluster.kill:
                signal.raise_signal(signal.SIGTERM)   # the group's signal, caught by the run's StopFlag
            raise RuntimeError('Nanny failed to start.')

    monkeypatch.setattr(distributed, 'LocalCluster', FailingCluster)
    monkeypatch.setattr(sched, 'start_workers_ignoring_sigint', lambda: None)
    monkeypatch.setattr(StopFlag, 'caught', None)
    model = load_workspace_model(config_path('mechanisms/tripod_3rps.yaml'))
    with Executor('local', 2) as ex:
        res = approximate(model, 0.0005, chunk_size=1024, parts=8, scheduler=ex)
    assert res.interrupted and res.stopped == 'interrupted' and StopFlag.caught == signal.SIGTERM
    assert not res.extra['cluster_used'] and res.boundary_boxes > 0
    FailingCluster.kill = False
    with Executor('local', 2) as ex, pytest.raises(RuntimeError, match='Nanny failed to start'):
        ex.run(lambda m, c: c, None, [1, 2], (), [None, None], lambda: False, lambda i, r: None)
