"""The one life cycle of every node process: init, build the node, spin, leave cleanly.

:func:`run` is the ``main`` of each executable. Exit statuses (documented in docs/ros.md):

- 0: the node finished its work or was stopped by SIGINT/SIGTERM;
- 1 (:data:`EXIT_FAILED`): it stopped while running (e.g. the recorder's disk is full): one line
  ``stopped: ...``;
- 2 (:data:`EXIT_BAD_CONFIG`): it cannot start (malformed ``--ros-args`` or params file, a params file beyond the
  bounds of :mod:`.params_files`, a bad parameter value, an unreadable program or bag, an invalid topic name): one
  line ``cannot start: ...``, never a traceback.

Signals: rclpy's own SIGINT/SIGTERM handlers are not installed (``SignalHandlerOptions.NO``); SIGINT and SIGTERM
only set a flag (:class:`StopFlag`) that the spin loop checks, so a signal never interrupts the construction of
an rclpy object half way (with rclpy's handlers a signal arriving while an executor was being built left it
without its guard condition, and its ``__del__`` printed an ``AttributeError``) and every node leaves through
the same path: :meth:`GprNode.on_exit` (drain, flush, close files), destroy the node, shut rclpy down.
"""
from __future__ import annotations

import contextlib
import ctypes
import os
import re
import signal
import sys
import threading
import time
from collections.abc import Callable, Coroutine, Iterable, Sequence
from typing import Any

import rclpy
from rcl_interfaces.msg import ParameterType, SetParametersResult
from rclpy.duration import Duration
from rclpy.exceptions import InvalidHandle, NameValidationException, ParameterException, ParameterNotDeclaredException
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor, await_or_execute
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.service import Service
from rclpy.signals import SignalHandlerOptions

from ..errors import EXIT_BAD_INPUT, GprError
from ..inputs.validation import decimal_number
from .params import unknown_overrides
from .params_files import check_params_files
from .stderr_hold import stderr_held

EXIT_OK = 0
#: Exit status of a node that stopped on an error while running.
EXIT_FAILED = 1
#: Exit status of a node that cannot start (bad arguments, parameters, files).
EXIT_BAD_CONFIG = EXIT_BAD_INPUT
#: Longest time [s] the spin loop waits before it looks at the stop flag again (the delay of a clean exit).
SPIN_TIMEOUT = 0.05
#: Most samples one timer tick of a streaming node publishes to make up for ticks the busy machine could not serve in
#: time (the trajectory node's stream, the simulator's joint states).
CATCH_UP = 5
#: Most samples one tick publishes under ``use_sim_time``: a simulated clock advances in steps (``ros2 bag play
#: --clock`` at 40 Hz, a simulator at 10 Hz), and every sample due at a step goes out at it, each stamped at its own
#: instant (a 10 Hz clock at a 5 kHz stream: 500).
SIM_CATCH_UP = 1000
#: Longest error text put on the one error line (a user's value is never printed whole).
MAX_MESSAGE = 600

# rclpy's C extension raises RCLError for malformed --ros-args and params files.
from rclpy._rclpy_pybind11 import RCLError  # noqa: E402 - grouped with its explanation

#: What a bad command line, parameter or input file raises while a node is built.
START_ERRORS: tuple[type[BaseException], ...] = (GprError, ParameterException, NameValidationException, RCLError)
#: rclpy's refusal of an integer given to a double parameter, and the integer.
_INTEGER_FOR_DOUBLE = re.compile(r"to '(-?\d+)' of type 'INTEGER', expecting type 'DOUBLE'")
#: rclpy's refusal of a value that is no list (or a list of integers) given to an array parameter, and the value.
_ONE_FOR_ARRAY = re.compile(r"to '([^']*)' of type '\w+', expecting type '(DOUBLE|STRING)_ARRAY'")


def type_hint(error: str) -> str:
    """The 'allowed:' rclpy's refusal of a parameter's type leaves out (``''`` for another error): a double written
    as an integer; a list for an array parameter (every double array is per rod: 3 values). A refusal that says what
    is allowed already (a bounded number's, :func:`~.params.declare_parameters`) gets nothing more."""
    if '; allowed: ' in error:
        return ''
    whole = _INTEGER_FOR_DOUBLE.search(error)
    if whole:
        return f'; allowed: a floating-point value (write {whole.group(1)}.0)'
    one = _ONE_FOR_ARRAY.search(error)
    if one is None:
        return ''
    if one.group(2) == 'STRING':
        return f"; allowed: a list of texts, e.g. ['{one.group(1)}']"
    given = [float(v) for v in re.findall(r'[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?', one.group(1))]
    if len(given) == 1:   # the form, not a value the node takes: its range is checked after (kappa:=0)
        v = repr(given[0])
        return f'; allowed: a list of 3 numbers, one per rod ([{v}, {v}, {v}] for {v} at each)'
    written = f' ([{", ".join(repr(v) for v in given)}]: floating-point)' if len(given) == 3 else ''
    return f'; allowed: a list of 3 numbers, one per rod{written}'


class StopFlag:
    """SIGINT/SIGTERM handlers that only record the signal; ``bool(flag)`` is true once one arrived."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.signals: list[int] = []
        for sig in self.SIGNALS:
            signal.signal(sig, self._on_signal)

    def _on_signal(self, signum: int, _frame: Any) -> None:
        self.signals.append(signum)

    def __bool__(self) -> bool:
        return bool(self.signals)


#: The flag of the run under way (:func:`run`): a node's start that waits (the recorder's discovery of types) asks it.
_STOP: list[StopFlag] = []


class StoppedAtStartError(Exception):
    """A stop signal arrived while the node was still starting (it waited for something): the run ends with status 0,
    nothing started (:func:`stop_requested`)."""


def stop_requested() -> bool:
    """Whether SIGINT or SIGTERM arrived during the run under way (False outside :func:`run`)."""
    return bool(_STOP) and bool(_STOP[-1])


def stop_signal() -> str:
    """The name of the first stop signal of the run under way (``SIGINT``, ``SIGTERM``; '' if none)."""
    return signal.Signals(_STOP[-1].signals[0]).name if _STOP and _STOP[-1].signals else ''


def numbers_from_text(node: Node, params: list[Parameter]) -> list[Parameter]:
    """Pre-set stage: a string that is a decimal number, set on a double parameter, becomes that double.

    YAML 1.1 (PyYAML, which the ``ros2`` CLI and rclpy's params-file loader use) reads ``1e-13`` as a string: so
    ``ros2 param set /kinematics_node tolerance 1e-13`` sends a string, and ``ros2 param load`` of a node's own
    ``ros2 param dump`` re-reads ``tolerance: 1.0e-14`` through ``str(1e-14) = '1e-14'`` as a string; rclpy would
    refuse both (wrong type). Other strings (:func:`~gpr_kinematics.inputs.validation.decimal_number`: longer than 64
    characters, or not a decimal number) pass unchanged and meet the type check.
    """
    out = []
    for p in params:
        if (p.type_ == Parameter.Type.STRING and node.has_parameter(p.name)
                and node.describe_parameter(p.name).type == ParameterType.PARAMETER_DOUBLE):
            number = decimal_number(p.value)
            if number is not None:
                p = Parameter(p.name, Parameter.Type.DOUBLE, number)
        out.append(p)
    return out


class QueueTimedExecutor(SingleThreadedExecutor):
    """rclpy's single-threaded executor that also notes when the request a service callback answers arrived at the
    node (``rmw_service_info_t.received_timestamp``, which rclpy takes but does not pass to the callback):
    :meth:`request_age` in the callback is how long the request waited in the node's queue. A response that cannot
    be sent (its client went away, or stopped reading while its queue is full) is dropped with a warning instead of
    ending the node (rclpy's action server does the same for goal responses). Otherwise rclpy's ``_take_service``
    (7.1, Jazzy), unchanged."""

    received_ns = 0

    def request_age(self) -> float:
        """Seconds the request being answered waited since it arrived (0 where the middleware gives no stamp)."""
        return max(time.time_ns() - self.received_ns, 0) / 1e9 if self.received_ns else 0.0

    def _take_service(self, srv: Service) -> Callable[[], Coroutine[Any, Any, None]] | None:
        srv_type: Any = srv.srv_type
        try:
            with srv.handle:
                request, header = srv.handle.service_take_request(srv_type.Request)
        except InvalidHandle:  # destroyed meanwhile: nothing to do
            return None
        if header is None:
            return None
        received = int(getattr(header, 'received_timestamp', 0) or 0)

        async def execute() -> None:
            self.received_ns = received
            response = await await_or_execute(srv.callback, request, srv_type.Response())
            try:
                srv.send_response(response, header)
            except (RCLError, InvalidHandle) as exc:
                rclpy.logging.get_logger('gpr_services').warning(
                    f'{srv.srv_name}: the response could not be sent (the client went away?): {one_line(exc)}')

        return execute


class GprNode(Node):
    """A node run by :func:`run`: :meth:`finish` ends the run with a status; :meth:`spin` and :meth:`on_exit`
    are the hooks a node overrides (the default spins callbacks until finished or stopped). Double parameters
    accept decimal numbers sent as strings (:func:`numbers_from_text`)."""

    NODE_NAME = 'gpr_node'

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(self.NODE_NAME, **kwargs)
        self.exit_status: int | None = None
        #: True once SIGINT/SIGTERM stopped the run (set before :meth:`on_exit`).
        self.signalled = False
        self.add_pre_set_parameters_callback(lambda params: numbers_from_text(self, params))
        self.add_on_set_parameters_callback(self._guarded)  # in front of rclpy's TimeSource, which applies a clock
        #: ``use_sim_time``, fixed once the node runs (:meth:`_guarded`): read once, not at every tick.
        self.simulated = bool(self.get_parameter('use_sim_time').value)

    def _guarded(self, params: list[Parameter]) -> SetParametersResult:
        """Refuse a parameter without a name (rclpy's check of undeclared names passes ``''``: any client created it,
        and a dump holding it does not load back) and a change of ``use_sim_time`` once the node runs (any client could
        switch a running node to a ``/clock`` that nobody publishes: its goals never ended, its timers never fired)."""
        now = self.get_parameter('use_sim_time').value
        for p in params:
            if p.name == '':
                return SetParametersResult(successful=False, reason="a parameter named '' (empty); allowed: the "
                                           "node's parameters (list_parameters)")
            if p.name == 'use_sim_time' and p.value != now:
                return SetParametersResult(successful=False, reason=f'use_sim_time = {p.value!r}: the clock is fixed '
                                           f'once the node runs (now {now}); allowed: set it at start (-p '
                                           'use_sim_time:=true, or the launch argument use_sim_time)')
        return SetParametersResult(successful=True)

    def _check_undeclared_parameters(self, parameter_list: list[Parameter]) -> None:
        """rclpy's check, naming the undeclared parameters and what is allowed (its generator, consumed by ``any``,
        listed none: ``Invalid access to undeclared parameter(s): []``)."""
        names = [p.name for p in parameter_list
                 if isinstance(p, Parameter) and p.name and p.name not in self._parameters]
        if names and not self._allow_undeclared_parameters:
            raise ParameterNotDeclaredException(f"{', '.join(map(repr, names))}; allowed: the node's parameters "
                                                '(list_parameters)')
        super()._check_undeclared_parameters(parameter_list)

    def pace_clock(self) -> float:
        """Seconds on the clock that paces the node's streams, as its timers run: the ROS clock under
        ``use_sim_time`` (a simulation slower than real time sets the pace: counted on the wall clock, every tick
        caught up :data:`CATCH_UP` samples and a stream ran five times too fast in simulated time), else
        ``time.monotonic`` (no jump of the system clock)."""
        if self.simulated:
            return float(self.get_clock().now().nanoseconds) * 1e-9
        return time.monotonic()

    def catch_up(self) -> int:
        """Most samples a tick publishes: :data:`SIM_CATCH_UP` under ``use_sim_time``, else :data:`CATCH_UP`."""
        return SIM_CATCH_UP if self.simulated else CATCH_UP

    def finish(self, status: int = EXIT_OK) -> None:
        """End the run loop with ``status`` (the first call wins)."""
        if self.exit_status is None:
            self.exit_status = status

    def make_executor(self) -> Executor:
        """The executor :func:`run` spins the node with: one thread (a node whose callbacks must run apart, such as
        an action served while a goal is planned, returns a multi-threaded one)."""
        return SingleThreadedExecutor()

    def spin(self, executor: Executor, stop: StopFlag) -> None:
        """Run callbacks until :meth:`finish` was called or a stop signal arrived."""
        while not stop and self.exit_status is None:
            executor.spin_once(timeout_sec=SPIN_TIMEOUT)

    def on_exit(self, executor: Executor, status: int) -> int:
        """Called once after :meth:`spin`, also after an error (``status`` 1); returns the exit status."""
        return status


#: On the way out, how long a goal ended there may take to reach its client [s], and the spinning after it ended
#: (a grace of 0.2 s: a test's client of a goal ended by SIGTERM missed its result once, in a loaded CI run; the
#: grace is spent only when a goal was running at the stop).
RESULT_WAIT = 3.0
RESULT_GRACE = 0.5


def deliver_results(executor: Executor, goals: Iterable[Any], seconds: float = RESULT_WAIT) -> None:
    """Spin ``executor`` until every goal handle of ``goals`` (``None`` skipped) has ended and :data:`RESULT_GRACE`
    longer, at most ``seconds``: rclpy sends a goal's result to its client from a callback the executor runs after
    the goal ends, so a goal ended by a stop signal reached no client when the action server was destroyed at
    once."""
    pending = [g for g in goals if g is not None]
    deadline = time.monotonic() + seconds
    grace = deadline
    while pending and time.monotonic() < grace:
        if grace == deadline and not any(g.is_active for g in pending):
            grace = min(deadline, time.monotonic() + RESULT_GRACE)
        with contextlib.suppress(RCLError):  # a timer the stop cancelled after the executor found it ready
            executor.spin_once(timeout_sec=0.02)


def wait_acknowledged(publishers: Iterable[Publisher], seconds: float) -> None:
    """Wait until every reliable subscription acknowledged what each publisher sent (at most ``seconds`` per
    publisher; best effort on the way out: an error is ignored)."""
    for pub in publishers:
        with contextlib.suppress(Exception):
            pub.wait_for_all_acked(Duration(seconds=seconds))


def tell(logger: Any, text: str, warning: bool) -> None:
    """Log ``text`` at the warning severity if ``warning``, else at info: each severity from its own line, since rclpy
    ties a call's line to the severity it first logged at (and raises at another one)."""
    if warning:
        logger.warning(text)
    else:
        logger.info(text)


def one_line(exc: BaseException) -> str:
    """The text of an error on one line, without rcl's source locations, at most :data:`MAX_MESSAGE` characters."""
    text = str(exc) or type(exc).__name__
    text = re.sub(r',? at [^,\s]*\.c(pp)?:\d+', '', text)
    text = text.replace('failed to initialize rcl: ', '')
    text = ' '.join(text.split())
    if isinstance(exc, RCLError) and 'params file' in text.lower():
        text += (' (a params file maps node names to {ros__parameters: {name: value}}, e.g. '
                 'share/gpr_kinematics/config/gpr_params.yaml)')
    return text if len(text) <= MAX_MESSAGE else text[:MAX_MESSAGE] + ' ...'


#: How long [s] a process whose start was refused may take to shut rclpy down before it leaves regardless.
REFUSED_EXIT_WAIT = 10.0


def _leaving(refused: int | None) -> None:
    """A process of its own, leaving: the stop signals ignored from now on (Python's exit restores the default
    handlers of the signals it handled, and a second Ctrl-C 0.2 s after the first ended a recorder that had closed its
    bag with status 130; ignored ones stay ignored), then a refused start ends at once (:func:`_leave`)."""
    for sig in StopFlag.SIGNALS:
        signal.signal(sig, signal.SIG_IGN)
    if refused is not None:
        _leave(refused)


def _leave(status: int) -> None:
    """End the process with ``status`` now: the streams flushed (Python's and the C library's), no finalisation."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    with contextlib.suppress(Exception):
        ctypes.CDLL(None).fflush(None)
    os._exit(status)


def finish_callbacks(executor: Executor) -> None:
    """Let the callbacks a ``MultiThreadedExecutor`` handed to its threads end before anything of the node goes: its
    ``shutdown`` destroys its guard conditions first, and a timer's tick still queued then failed on them or on the
    cancelled timer ('The following exception was never retrieved: cannot use Destroyable ...' at a stop mid-stream).
    No new callback is taken after (the node is leaving)."""
    pool = getattr(executor, '_executor', None)   # rclpy's ThreadPoolExecutor of the MultiThreadedExecutor
    if pool is not None:
        pool.shutdown(wait=True)


def _init(args: Sequence[str] | None, logger: Any) -> bool:
    """rclpy initialised with ``args`` (None: ``sys.argv``), its params files first read under the package's bounds
    (:mod:`.params_files`: rcl's parser is quadratic and deaf to signals); False after the one ``cannot start`` line."""
    try:
        check_params_files(sys.argv if args is None else args)
    except GprError as exc:
        logger.error(f'cannot start: {one_line(exc)}')
        return False
    try:
        with stderr_held():
            rclpy.init(args=None if args is None else list(args), signal_handler_options=SignalHandlerOptions.NO)
    except RCLError as exc:
        logger.error(f'cannot start: {init_refusal(exc)}')
        rclpy.try_shutdown()   # a context rcl made before its logging refused
        return False
    return True


def init_refusal(exc: RCLError) -> str:
    """Why ``rclpy.init`` refused: its logging without a log folder it can write (``HOME`` unset: it read "malformed
    ROS arguments" where none were given), a ``ROS_DOMAIN_ID`` that is no number, else the arguments."""
    text = one_line(exc)
    if 'ROS_DOMAIN_ID' in text:
        return f'{text}; allowed: ROS_DOMAIN_ID unset or an integer from 0 to 232'
    if 'initialize logging' not in text:
        return f'malformed ROS arguments: {text}'
    text = re.sub(r': (\d+)$', lambda m: f': {os.strerror(int(m.group(1)))}', text)
    return (f'ROS logging cannot start ({text}): its files go to $ROS_LOG_DIR, else $ROS_HOME/log, else ~/.ros/log '
            '(of $HOME), a folder it must create and write; allowed: ROS_LOG_DIR (or ROS_HOME, or HOME) writable')


def run(node_class: type[GprNode], args: Sequence[str] | None = None, name: str | None = None) -> int:
    """Init rclpy (signals: :class:`StopFlag`), build the node, spin it, leave; return the exit status. The node is
    destroyed before rclpy shuts down, also one whose start was refused half-way (its handles had been left to the
    garbage collector after the shutdown, where rclpy and Fast DDS are known to hang now and then: one of five
    refused recorders did not exit in 30 s on a loaded CI machine, and once more in a CI run after that mend). A
    process started from its console script (``args`` None) whose start was refused then leaves at once with its
    status, skipping the interpreter's finalisation, and within :data:`REFUSED_EXIT_WAIT` whatever the shutdown
    does; called with ``args`` (in a test's process) it returns."""
    logger = rclpy.logging.get_logger(name or str(getattr(node_class, 'NODE_NAME', 'gpr_node')))
    stop = StopFlag()
    _STOP[:] = [stop]
    if not _init(args, logger):
        return EXIT_BAD_CONFIG
    node: GprNode | None = None
    executor: Executor | None = None
    refused: int | None = None
    try:
        try:
            node = node_class.__new__(node_class)   # bound before __init__: a refused start still destroys its node
            node_class.__init__(node)
        except StoppedAtStartError as exc:
            logger.info(f'stopped before it started: {one_line(exc)}')
            return EXIT_OK
        except START_ERRORS as exc:   # rclpy takes no integer for a double: '-p rate:=200' (a double: 200.0)
            logger.error(f'cannot start: {one_line(exc)}{type_hint(str(exc))}')
            refused = EXIT_BAD_CONFIG
            return refused
        except Exception as exc:  # noqa: BLE001 - one line, no traceback, even for a bug
            logger.error(f'cannot start: internal error: {type(exc).__name__}: {one_line(exc)}')
            refused = EXIT_FAILED
            return refused
        unknown_overrides(node)
        executor = node.make_executor()
        executor.add_node(node)
        status = EXIT_OK
        try:
            node.spin(executor, stop)
            status = node.exit_status or EXIT_OK
        except ExternalShutdownException:
            status = EXIT_OK
        except Exception as exc:  # noqa: BLE001 - an error while running: one line, by the node's own (remapped) name
            node.get_logger().error(f'stopped: {type(exc).__name__}: {one_line(exc)}')
            status = EXIT_FAILED
        node.signalled = bool(stop)
        try:
            return node.on_exit(executor, status)
        except Exception as exc:  # noqa: BLE001 - leaving anyway, with one line
            node.get_logger().error(f'stopped: {type(exc).__name__}: {one_line(exc)}')
            return EXIT_FAILED
    finally:
        own = args is None   # a process of its own (not a test's call)
        if own and refused is not None:
            watchdog = threading.Timer(REFUSED_EXIT_WAIT, _leave, (refused,))
            watchdog.daemon = True
            watchdog.start()
        if executor is not None:
            with contextlib.suppress(Exception):
                executor.shutdown()
        if node is not None:
            with contextlib.suppress(Exception):
                node.destroy_node()
        rclpy.try_shutdown()
        if own:
            _leaving(refused)
