"""Test configuration: the ``ros`` marker and the ROS environment of the tests that need it.

``pytest -m ros`` runs the tests over real DDS (nodes as separate processes, the colcon build of ``make setup``);
``pytest -m "not ros"`` runs everything else, without the colcon build or ROS. ``slow`` marks the tests that take
2 s or more alone (6 s for a test marked ``ros``): ``make test-quick`` and the stock run leave them out. A test
module opts in with ``pytestmark = pytest.mark.ros``: its fixtures and tests then run in the environment of
:func:`ros_environment` (no import side effect: ROS packages are imported inside the tests, after it).

Every ROS test of a run shares one ``ROS_DOMAIN_ID``: ``GPR_TEST_ROS_DOMAIN_ID`` when set (give parallel runs on
one host different values), else ``10 + pid % 90``; discovery stays on localhost.
"""
from __future__ import annotations

import os
import signal
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# `python -m pytest` at the repository's root puts the root first on sys.path, where the folder of the ROS package
# gpr_kinematics/ (no __init__.py) would shadow the installed Python package as an empty namespace package.
sys.path[:] = [p for p in sys.path if Path(p or os.curdir).resolve() != ROOT]
sys.path.insert(0, str(Path(__file__).resolve().parent))  # ros_support, for the test modules
# A suite started in the background (`make test &` from a script) inherits SIGINT ignored, and every command and node
# it starts would too: the tests of Ctrl-C then failed (a command ran to its end, a node did not stop). Python's
# own handler back, as in a terminal; a started process then gets SIGINT's default.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line('markers', 'ros: needs the colcon build (make setup) and runs nodes over real DDS')
    config.addinivalue_line('markers', 'slow: takes 2 s or more alone (a test marked ros: 6 s or more); left out of '
                                       'make test-quick and of the stock run (make test runs it on the pinned '
                                       'versions)')


#: Reruns of a failed test marked ``ros`` (pytest-rerunfailures, where installed): its nodes run over DDS as processes
#: on a machine the other suite loads too, and a discovery wait, a burst of messages or a result in flight is late
#: now and then (about one run in three of ``make test`` failed one of 290 such tests, a different one each time,
#: each passing alone); as the ROS 2 buildfarm's ``colcon test --retest-until-pass``, a test that fails twice fails.
#: Tests not marked ``ros`` are never rerun.
ROS_RERUNS = 1


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark every test marked ``ros`` for :data:`ROS_RERUNS` reruns, with pytest-rerunfailures installed."""
    if not config.pluginmanager.hasplugin('rerunfailures'):
        return
    for item in items:
        if item.get_closest_marker('ros') is not None and item.get_closest_marker('flaky') is None:
            item.add_marker(pytest.mark.flaky(reruns=ROS_RERUNS, reruns_delay=1))


def test_domain_id() -> int:
    """The ``ROS_DOMAIN_ID`` of this run's ROS tests."""
    value = os.environ.get('GPR_TEST_ROS_DOMAIN_ID')
    if value is None:
        return 10 + os.getpid() % 90
    if not value.isdigit() or not 0 <= int(value) <= 232:
        raise pytest.UsageError(f'GPR_TEST_ROS_DOMAIN_ID = {value!r}; allowed: an integer from 0 to 232')
    return int(value)


test_domain_id.__test__ = False  # type: ignore[attr-defined]  # a helper, not a test


@pytest.fixture(scope='session')
def ros_environment() -> Iterator[dict[str, str]]:
    """Put this process, and every node it starts, into the repository's ROS environment
    (:func:`gpr_kinematics.ros.env.activate`: what ``source install/setup.bash`` gives), with this run's
    ``ROS_DOMAIN_ID``, ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and ``ROS_PYTHON_CHECK_FIELDS=1`` (message
    field checks, off by default in Jazzy). If ROS cannot be imported the tests fail, they never skip."""
    from gpr_kinematics.ros import env as ros_env

    saved = dict(os.environ)
    os.environ['ROS_DOMAIN_ID'] = str(test_domain_id())
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    os.environ['ROS_PYTHON_CHECK_FIELDS'] = '1'
    os.environ['PYTHONUNBUFFERED'] = '1'
    ros_env.activate()
    import rclpy  # noqa: F401 - fail here, once, if ROS is not importable

    yield dict(os.environ)
    os.environ.clear()
    os.environ.update(saved)


@pytest.fixture(autouse=True, scope='module')
def _ros_marked_module(request: pytest.FixtureRequest) -> None:
    """Modules marked ``ros`` get :func:`ros_environment` before any of their fixtures."""
    if request.node.get_closest_marker('ros') is not None:
        request.getfixturevalue('ros_environment')


@pytest.fixture(autouse=True)
def _no_progress_line_unless_asked(monkeypatch: pytest.MonkeyPatch) -> None:
    """A command run in the test's process shows no progress line (``cli.progress.AFTER``: 2 s of wall time, which a
    loaded machine reaches where a quiet one does not, and its stderr then held lines its test did not expect); the
    tests of the line set ``AFTER`` themselves (0 s: shown from the start)."""
    monkeypatch.setattr('gpr_kinematics.cli.progress.AFTER', float('inf'))
