"""Process life cycle shared by the nodes: init, spin, clean exit on SIGINT/SIGTERM."""
from __future__ import annotations

import signal
from collections.abc import Callable, Sequence
from typing import Any

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from ..errors import GprError

#: Exit status when the node cannot start (bad parameters, unreadable program).
EXIT_BAD_CONFIG = 2


def init_with_stop_flag(args: Sequence[str] | None = None) -> list[int]:
    """Init rclpy without its signal handlers; SIGINT and SIGTERM append their number to the returned list.

    For nodes that must finish work after a stop request (the recorder drains and closes its bag, replay
    waits for acknowledgements) instead of having rclpy tear the context down under them.
    """
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stop: list[int] = []

    def on_signal(signum: int, _frame: Any) -> None:
        stop.append(signum)

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    return stop


def run(name: str, factory: Callable[[], Node], args: Sequence[str] | None = None,
        spin: Callable[[Node], int] | None = None) -> int:
    """Init rclpy, build the node and spin it until shutdown.

    Returns 0 after SIGINT/SIGTERM (rclpy's signal handlers turn them into ``KeyboardInterrupt`` or
    ``ExternalShutdownException``; caught here: no traceback) or when ``spin`` returns 0;
    :data:`EXIT_BAD_CONFIG` when the node cannot start, with one error line naming the problem.
    """
    rclpy.init(args=args)
    node = None
    status = 0
    try:
        node = factory()
        status = spin(node) if spin is not None else _spin_forever(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        status = 0
    except (GprError, ParameterException) as exc:
        rclpy.logging.get_logger(name).error(f'cannot start: {exc}')
        status = EXIT_BAD_CONFIG
    except Exception as exc:  # noqa: BLE001 - one line, no traceback
        if rclpy.ok():
            rclpy.logging.get_logger(name).error(f'stopped: {type(exc).__name__}: {exc}')
            status = 1
        else:
            status = 0  # a signal shut the context down while a callback was answering: a normal exit
    finally:
        if node is not None:
            try:
                node.destroy_node()
            except Exception:  # noqa: BLE001 - leaving anyway; never a traceback on exit
                pass
        rclpy.try_shutdown()
    return status


def _spin_forever(node: Node) -> int:
    rclpy.spin(node)
    return 0
