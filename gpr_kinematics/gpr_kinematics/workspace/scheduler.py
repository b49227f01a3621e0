"""Where the chunks of a covering level run: in this process, or on a ``dask.distributed`` cluster.

The covering processes its pending boxes level by level; each level is cut into chunks of a fixed size
(the same cut whatever runs them), each chunk is classified by a pure function of the model and the
chunk, and the results are put back together in chunk order. So one process and any cluster give
exactly the same boxes in the same order (on workers with the same numpy and libm).

``scheduler``:

* ``'none'``: every chunk in this process, one after the other;
* ``'local'``: a ``distributed.LocalCluster`` with one single-threaded worker process per core (or
  ``workers``), started the first time a level has more than one chunk (small runs never start it); its workers
  ignore SIGINT (:func:`start_workers_ignoring_sigint`);
* ``'tcp://HOST:PORT'`` (or ``tls://``): an existing Dask scheduler; its workers need this package
  installed (same version). It is connected to when the :class:`Executor` is made, before any work: an address
  where nothing listens is an error at once (a TCP connection is tried first, so a refused one does not wait for
  Dask's retries), whatever the size of the run.

``dask`` and ``distributed`` are imported only here, only when a cluster is asked for.
"""

from __future__ import annotations

import logging
import os
import re
import signal
import socket
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..errors import InputError, brief

SCHEDULERS = ('local', 'none')
_ADDRESS = re.compile(r'(tcp|tls)://[A-Za-z0-9_.\-\[\]:]+:[0-9]{1,5}')
#: Seconds to wait for an existing scheduler before giving up.
CONNECT_TIMEOUT = 10.0
#: Most worker processes of a local cluster.
MAX_WORKERS = 256

StepFunction = Callable[..., Any]


def check_scheduler(scheduler: str, workers: int | None = None, names: tuple[str, str] = ('workers', 'scheduler')
                    ) -> None:
    """Refuse a scheduler that is neither ``none``, ``local`` nor a ``tcp://HOST:PORT`` address, and ``workers``
    outside ``[1, MAX_WORKERS]`` or beside another scheduler than ``local``; ``names``: the two as the caller's user
    gives them (``--workers``, ``--scheduler``)."""
    if not isinstance(scheduler, str) or not (scheduler in SCHEDULERS or _ADDRESS.fullmatch(scheduler)):
        raise InputError(
            f'scheduler {str(scheduler)[:80]!r} is not allowed; allowed: none, local or a Dask scheduler '
            'address tcp://HOST:PORT'
        )
    if workers is not None and (isinstance(workers, (bool, np.bool_)) or not isinstance(workers, (int, np.integer))
                                or not 1 <= workers <= MAX_WORKERS):   # np.int64(2) too
        raise InputError(f'{names[0]} = {brief(workers)}; allowed: an integer from 1 to {MAX_WORKERS}')
    if workers is not None and scheduler != 'local':
        raise InputError(f'{names[0]} = {brief(workers)} with {names[1]} {scheduler}; allowed: {names[0]} with '
                         f'{names[1]} local only (an existing cluster has its own workers)')


def check_reachable(address: str) -> None:
    """A TCP connection to the scheduler ``address`` (``tcp://HOST:PORT``) can be opened within
    :data:`CONNECT_TIMEOUT`; :class:`InputError` naming the address and the reason otherwise."""
    host, _, port = address.split('://', 1)[1].rpartition(':')
    try:
        socket.create_connection((host.strip('[]'), int(port)), timeout=CONNECT_TIMEOUT).close()
    except (OSError, ValueError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc) or type(exc).__name__
        raise InputError(f'cannot reach the Dask scheduler at {address}: {reason[:200]}; allowed: the address of a '
                         'running scheduler, or --scheduler local or none') from None


def _remote_client(client_class: Any, address: str) -> Any:
    """A ``distributed.Client`` of the scheduler at ``address``, made in a thread of its own so that a server that
    accepts the connection but never answers (not a Dask scheduler) is given up after :data:`CONNECT_TIMEOUT`
    (Dask's own timeout does not cover its handshake); :class:`InputError` otherwise."""
    box: dict[str, Any] = {}

    def connect() -> None:
        try:
            box['client'] = client_class(address, timeout=CONNECT_TIMEOUT)
        except MemoryError:   # Dask read a length from bytes that are not its protocol (3 EiB to allocate)
            box['error'] = 'its answer is not the Dask protocol (is it a Dask scheduler?)'
        except BaseException as exc:  # noqa: BLE001 - in this thread, whatever Dask raises becomes the one line
            box['error'] = f'{str(exc).splitlines()[0][:200] if str(exc) else type(exc).__name__}'

    thread = threading.Thread(target=connect, name='gpr-dask-connect', daemon=True)
    thread.start()
    thread.join(CONNECT_TIMEOUT + 1.0)
    if 'client' in box:
        return box['client']
    if 'error' in box:   # it failed at once: "within 10 s" was no reason
        raise InputError(f'cannot connect to the Dask scheduler at {address}: {box["error"]}')
    raise InputError(f'cannot connect to the Dask scheduler at {address} within {CONNECT_TIMEOUT:g} s: no answer (is '
                     'it a Dask scheduler?)')


def start_workers_ignoring_sigint() -> None:
    """Have a local cluster's worker processes forked by a server started with SIGINT blocked: they inherit the mask
    (the server ignores SIGINT itself once started), so a terminal's Ctrl-C, sent to the whole process group, neither
    kills a worker as it starts ("Nanny failed to start") nor prints its KeyboardInterrupt traceback (65 lines at a
    Ctrl-C during a run); the cluster's close stops them. Only this thread blocks SIGINT, and only meanwhile: a Ctrl-C
    then reaches this process's handler, through another thread at once or here when the mask is given back. (It was
    ignored process-wide meanwhile: a Ctrl-C that another thread took, or that came once the resource tracker's start
    had unblocked it, was lost, and the run went on to its limits.) The resource tracker is started first, as its start
    gives SIGINT back to this thread."""
    import multiprocessing
    from multiprocessing import forkserver, resource_tracker

    import dask
    from distributed.utils import get_mp_context
    if 'forkserver' not in multiprocessing.get_all_start_methods():
        return
    dask.config.set({'distributed.worker.multiprocessing-method': 'forkserver'})
    get_mp_context()   # the server's preload (distributed and its packages), set before it starts
    if threading.current_thread() is not threading.main_thread():   # the signal mask: the main thread's only
        forkserver.ensure_running()
        return
    resource_tracker.ensure_running()   # blocks SIGINT for its child, then unblocks it in this thread
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        forkserver.ensure_running()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


class Executor:
    """Runs the chunks of one level and returns their results in chunk order."""

    def __init__(self, scheduler: str = 'none', workers: int | None = None) -> None:
        check_scheduler(scheduler, workers)
        self.scheduler = scheduler
        self.workers = workers
        self._client: Any = None
        self._cluster: Any = None
        self._model_key: Any = None
        self._model_future: Any = None
        self.used_cluster = False
        if scheduler not in SCHEDULERS:
            check_reachable(scheduler)
            self._connect()

    # ----------------------------------------------------------------------------------------- running
    def run(
        self,
        step: StepFunction,
        model: Any,
        chunks: Sequence[Any],
        args: tuple[Any, ...],
        results: list[Any],
        stop: Callable[[], bool],
        done: Callable[[int, Any], None],
        tick: Callable[[], None] | None = None,
    ) -> None:
        """``results[i] = step(model, chunks[i], *args)`` for every chunk, except those not run because
        ``stop()`` became true (checked between chunks; they stay as they were, ``None``). ``done(i, result)``
        is called as each result arrives, ``tick()`` about twice a second while waiting for a cluster. An
        exception (KeyboardInterrupt included) leaves the results recorded so far in ``results``."""
        if self.scheduler == 'none' or len(chunks) <= 1:
            for i, chunk in enumerate(chunks):
                if stop():
                    break
                results[i] = step(model, chunk, *args)
                done(i, results[i])
            return
        client = self._connect(stop)
        if client is None or stop():   # a signal while a local cluster started: nothing run, the run stops
            return
        try:
            self._run_on(client, step, model, chunks, args, results, stop, done, tick)
        except Exception:
            if not stop():   # SIGTERM to the process group killed the workers too: "Stream is closed" from a scatter
                raise

    def _run_on(self, client: Any, step: StepFunction, model: Any, chunks: Sequence[Any], args: tuple[Any, ...],
                results: list[Any], stop: Callable[[], bool], done: Callable[[int, Any], None],
                tick: Callable[[], None] | None) -> None:
        if self._model_key is not model:
            self._model_future = client.scatter(model, broadcast=True, hash=False)
            self._model_key = model
        waiting = {i: client.submit(step, self._model_future, c, *args, pure=False) for i, c in enumerate(chunks)}
        last = time.monotonic()
        try:
            while waiting and not stop():
                ready = [i for i, f in waiting.items() if f.done()]
                if not ready:
                    time.sleep(0.01)
                    if tick is not None and time.monotonic() - last > 0.5:
                        tick()
                        last = time.monotonic()
                    continue
                for i in ready:
                    results[i] = waiting.pop(i).result()
                    done(i, results[i])
        finally:
            if waiting:
                client.cancel(list(waiting.values()))

    def forget_model(self) -> None:
        """Send the model again at the next run (a run may have changed it, e.g. the joint area's tables)."""
        self._model_key = self._model_future = None

    # --------------------------------------------------------------------------------------- the cluster
    def _connect(self, stop: Callable[[], bool] | None = None) -> Any:
        """The client, made at the first call; ``None`` when ``stop()`` became true while a local cluster failed to
        start (SIGTERM to the process group killed its workers: "Nanny failed to start" ended in a traceback)."""
        if self._client is not None:
            return self._client
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            raise InputError(
                f"--scheduler {self.scheduler} needs dask.distributed (pip install '.[cluster]': dask, distributed); "
                'use --scheduler none for one process'
            ) from None
        if self.scheduler == 'local':
            try:
                start_workers_ignoring_sigint()
                self._start_local(LocalCluster, Client)
            except BaseException:
                if stop is None or not stop():
                    raise
                self.close()
                return None
        else:
            self._client = _remote_client(Client, self.scheduler)
        self.used_cluster = True
        return self._client

    def _start_local(self, cluster_class: Any, client_class: Any) -> None:
        n = int(self.workers or os.cpu_count() or 1)   # np.int64 given: a Python int for Dask
        self._cluster = cluster_class(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            # None served it on 8787 all the same: a second run printed distributed's "Port 8787 is already in
            # use" warning with its source line; a free port of this host only
            dashboard_address='127.0.0.1:0',
            # a worker's heartbeat in flight when the cluster closes logs an ERROR with its traceback (a SIGTERM
            # seen to print one to the user); a task's error still reaches the client as its exception
            silence_logs=logging.CRITICAL,
        )
        self._client = client_class(self._cluster)

    def describe(self) -> dict[str, Any]:
        """What ran the chunks: ``scheduler`` as asked, and the workers when a cluster was used."""
        out: dict[str, Any] = {'scheduler': self.scheduler, 'cluster_used': self.used_cluster}
        if self._client is not None:
            try:
                out['workers'] = len(self._client.scheduler_info().get('workers', {}))
            except Exception:  # noqa: BLE001 - a vanished cluster only loses this report line
                out['workers'] = None
        return out

    def close(self) -> None:
        if self._client is not None:
            self._client.close()
            self._client = None
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None
        self._model_key = self._model_future = None

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
