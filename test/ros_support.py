"""Helpers of the ROS tests that are not fixtures (the fixtures are in conftest.py). No import side effect."""
from __future__ import annotations

import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from gpr_kinematics.ros.process import NodeProcess


def params(**values: Any) -> list[str]:
    """``-p name:=value`` arguments (floats with ``repr``, so no digit is lost; booleans lower case)."""
    out: list[str] = []
    for name, value in values.items():
        text = ('true' if value else 'false') if isinstance(value, bool) else \
            repr(value) if isinstance(value, float) else str(value)
        out += ['-p', f'{name}:={text}']
    return out


def start(exe: str, *ros_args: str, namespace: str = '', **values: Any) -> NodeProcess:
    """Start ``exe`` as ``ros2 run`` would, with ``-r __ns:=namespace`` and ``-p`` parameters."""
    args = (['-r', f'__ns:={namespace}'] if namespace else []) + params(**values) + list(ros_args)
    return NodeProcess(exe, args)


def running(proc: NodeProcess, ready: str | None = None) -> Iterator[NodeProcess]:
    """A module fixture's body: ``proc`` (once its output shows ``ready``, if given), stopped after the module."""
    try:
        if ready is not None:
            wait_for_log(proc, ready)
        yield proc
    finally:
        proc.stop()


def client_session(name: str, namespace: str = '') -> Iterator[Any]:
    """A module fixture's body: a ``GprClient`` named ``name`` in ``namespace`` (imported here, once the ROS
    environment is active), closed after the module."""
    from gpr_kinematics.nodes.client import GprClient

    with GprClient(name, namespace=namespace) as c:
        yield c


def wait_for_log(proc: NodeProcess, pattern: str, timeout: float = 30.0) -> re.Match[str]:
    """The first match of ``pattern`` in the node's output (AssertionError with the output after ``timeout``)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        m = re.search(pattern, proc.output())
        if m:
            return m
        if not proc.alive():
            break
        time.sleep(0.05)
    m = re.search(pattern, proc.output())
    if m:
        return m
    raise AssertionError(f'{proc.exe}: no {pattern!r} in its output:\n{proc.output()}')


def vec(v: Any) -> np.ndarray:
    """(x, y, z) of a Point or Vector3."""
    return np.array([v.x, v.y, v.z])


def quat(q: Any) -> np.ndarray:
    """(x, y, z, w) of a Quaternion."""
    return np.array([q.x, q.y, q.z, q.w])


def assert_one_error_line(output: str, status: int, expected: int, *words: str) -> str:
    """A refused start or a stop on error: exit status ``expected``, no traceback, exactly one ERROR line, which
    contains every regular expression of ``words``; returns that line."""
    errors = [line for line in output.splitlines() if '[ERROR]' in line]
    assert status == expected, output
    assert 'Traceback' not in output, output
    assert len(errors) == 1, output
    for w in words:
        assert re.search(w, errors[0]), (w, errors[0])
    return errors[0]


#: A real, imperfect machine as a calibration writes it (docs/core.md): rods off their circle, zero offsets, rods not
#: parallel, platform joints moved, the compliant model with a kappa per joint; keys that no ROS parameter holds
#: (rod_positions, rod_directions, platform_joints) reach a node only through its config_file.
IMPERFECT_MACHINE = {
    'rod_positions': [[0.09326, 2e-5], [-0.04659, 0.08075], [-0.04664, -0.08071]],
    'rod_offsets': [4e-5, -1e-5, 2e-5],
    'rod_directions': [[2e-4, -1e-4], [-1e-4, 1.5e-4], [5e-5, 1e-4]],
    'platform_joints': [[0.09320, -1e-5], [-0.04663, 0.08073], [-0.04660, -0.08074]],
    'kappa': [5.0, 3.0, 8.0],
    'model': 'compliant',
}


def imperfect_config_file(folder: Any) -> tuple[Any, Any]:
    """Write :data:`IMPERFECT_MACHINE` as a geometry file in ``folder``; its path and the loaded configuration."""
    import yaml
    from gpr_kinematics.core.config import load_config

    path = folder / 'imperfect_gpr.yaml'
    path.write_text(yaml.safe_dump(IMPERFECT_MACHINE))
    return path, load_config(path)


#: What the file beside an operator's program folder holds (:func:`program_folder`): no answer may quote it.
SECRET = 's3cr3t-value'


def program_folder(root: Path, dwell: float) -> Path:
    """An operator's program folder (a node's ``program_folders``) in ``root``, with its hostile neighbours: a secret
    beside it, a link out of it, programs naming a robot or importing stations outside it; and ``short.yaml``, a
    one-station program dwelling ``dwell`` s. Returns the folder."""
    (root / 'secret.yaml').write_text(f'token: {SECRET}\n')
    folder = root / 'allowed'
    folder.mkdir()
    (folder / 'link_out.yaml').symlink_to(root / 'secret.yaml')
    (folder / 'names_outside.yaml').write_text(
        'format: gpr_robot_program\nrobot: ../secret.yaml\nstations: [{name: a, position: [1.3, 0.6, 0.45]}]\n'
        'steps: [{move: a}]\n')
    (folder / 'imports_outside.yaml').write_text(
        'format: gpr_robot_program\nimport: [../secret.yaml]\nsteps: [{move: a}]\n')
    (folder / 'short.yaml').write_text(
        f'stations: [{{name: s, height: 0.3, tilt: 0.0, azimuth: 0.0, dwell: {dwell}}}]\n')
    return folder
