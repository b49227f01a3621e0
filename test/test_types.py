"""Types that hold at the boundaries: no ``Any`` in a signature of ``core/`` and ``cli/`` where a concrete type exists,
and ``--json`` built from the result dataclasses (``cli/output.py``'s ``jsonable``) with the keys the docs name.

An ``Any`` that is honest stays under a name that says why (:data:`HONEST_ANY`): a YAML value before its format has
checked it, a ROS message of a class generated at run time, a config's derived constants typed where they are made,
the arguments a subclass forwards to ``argparse``. Modules other parts of the project are reworking are listed in
:data:`NOT_YET_CHECKED` until their work lands.
"""
from __future__ import annotations

import ast
import dataclasses
import json
import math

import numpy as np
import pytest
from gpr_kinematics.cli.output import emit_json, json_object, jsonable
from gpr_kinematics.core.mobility import analyze_mobility, rod_change
from gpr_kinematics.errors import InputError
from gpr_kinematics.mechanisms import load_mechanism
from gpr_kinematics.mechanisms.pose_analysis import analyse_pose
from gpr_kinematics.robot.forward import robot_forward
from gpr_kinematics.robot.inverse import solve_stations
from gpr_kinematics.robot.stations import Stations
from robot_support import ROBOT
from test_core_cli import run_json
from test_layout import PACKAGE_DIR

#: The package's honest ``Any``: alias -> the module (under the package) that defines it as ``Any``, with a ``#:``
#: comment saying why no concrete type names it.
HONEST_ANY = {
    'YamlValue': 'inputs/safe_yaml.py',
    'RosMessage': 'core/messages.py',
    'Derived': 'core/config.py',
    'Forwarded': 'cli/main.py',
}
#: The subpackages whose signatures are checked.
CHECKED = ('core', 'cli')
#: Modules of other parts of the project (cells work): not yet checked, added when it lands.
NOT_YET_CHECKED = {'cli/program.py'}


def _mentions_any(node: ast.AST | None) -> bool:
    """The annotation ``node`` names ``Any`` (``Any``, ``typing.Any``, or inside a string annotation)."""
    for n in ast.walk(node) if node is not None else ():
        if (isinstance(n, ast.Name) and n.id == 'Any') or (isinstance(n, ast.Attribute) and n.attr == 'Any'):
            return True
        if isinstance(n, ast.Constant) and isinstance(n.value, str):
            try:
                if _mentions_any(ast.parse(n.value, mode='eval')):
                    return True
            except SyntaxError:
                continue
    return False


def any_in_signatures(source: str) -> list[str]:
    """``line name`` of every parameter, return value and class field annotated with ``Any``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            a = node.args
            params = [p for p in (*a.posonlyargs, *a.args, a.vararg, *a.kwonlyargs, a.kwarg) if p is not None]
            found += [f'{p.lineno} {node.name}({p.arg})' for p in params if _mentions_any(p.annotation)]
            if _mentions_any(node.returns):
                found.append(f'{node.lineno} {node.name} -> ')
        elif isinstance(node, ast.ClassDef):
            found += [f'{s.lineno} {node.name}.{ast.unparse(s.target)}' for s in node.body
                      if isinstance(s, ast.AnnAssign) and _mentions_any(s.annotation)]
    return found


def any_aliases(source: str) -> dict[str, tuple[int, bool]]:
    """Module-level names whose value mentions ``Any`` -> (line, whether a ``#:`` comment precedes them)."""
    lines = source.splitlines()
    out = {}
    for node in ast.parse(source).body:
        value = node.value if isinstance(node, (ast.Assign, ast.AnnAssign)) else None
        if value is None or not _mentions_any(value):
            continue
        targets = node.targets if isinstance(node, ast.Assign) else [node.target]
        for t in targets:
            out[ast.unparse(t)] = (node.lineno, node.lineno >= 2 and lines[node.lineno - 2].lstrip().startswith('#:'))
    return out


def _checked_modules() -> list[str]:
    return sorted(str(p.relative_to(PACKAGE_DIR)) for sub in CHECKED for p in (PACKAGE_DIR / sub).glob('*.py')
                  if str(p.relative_to(PACKAGE_DIR)) not in NOT_YET_CHECKED)


def test_no_any_in_a_signature_of_core_and_cli():
    found = [f'{m}:{hit}' for m in _checked_modules()
             for hit in any_in_signatures((PACKAGE_DIR / m).read_text(encoding='utf-8'))]
    assert found == [], ('Any in a signature where a concrete type exists (or name the honest Any, HONEST_ANY): '
                         + '; '.join(found))


def test_any_is_named_only_by_the_honest_aliases_each_with_its_reason():
    defined = {}
    for m in sorted(set(_checked_modules()) | set(HONEST_ANY.values())):
        for name, (line, commented) in any_aliases((PACKAGE_DIR / m).read_text(encoding='utf-8')).items():
            defined[name] = (m, line, commented)
    assert {n: d[0] for n, d in defined.items()} == HONEST_ANY
    assert [f'{m}:{line} {n}' for n, (m, line, commented) in defined.items() if not commented] == []


def test_not_yet_checked_names_modules_that_exist():
    assert sorted(m for m in NOT_YET_CHECKED if not (PACKAGE_DIR / m).is_file()) == []


def test_the_checks_find_what_they_look_for():
    src = ('from typing import Any\nimport typing\nX = dict[str, Any]\n#: why\nY = Any\n'
           'def f(a: int, *b: Any, c: "list[Any]" = None, **d: int) -> typing.Any: ...\n'
           'class C:\n    x: Any\n    y: int = 0\n    def g(self, z: X) -> None: ...\n')
    assert any_in_signatures(src) == ['6 f(b)', '6 f(c)', '6 f -> ', '8 C.x']
    assert any_aliases(src) == {'X': (3, False), 'Y': (5, True)}


# --- --json: the result dataclasses through jsonable -------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class _Inner:
    v: np.ndarray
    n: np.int64


@dataclasses.dataclass(frozen=True)
class _Outer:
    name: str
    inner: tuple[_Inner, ...]
    extra: dict[str, object] = dataclasses.field(metadata={'json': 'inline'})


def test_jsonable_makes_json_data_of_dataclasses_arrays_and_inline_fields():
    obj = _Outer('a', (_Inner(np.arange(3.0), np.int64(7)),), {'k': (1, None), 'm': np.float64(0.5)})
    assert jsonable(obj) == {'name': 'a', 'inner': [{'v': [0.0, 1.0, 2.0], 'n': 7}], 'k': [1, None], 'm': 0.5}
    assert json.loads(json.dumps(jsonable(obj))) == jsonable(obj)
    with pytest.raises(TypeError, match='gives the keys'):
        jsonable(_Outer('a', (), {'name': 'twice'}))
    with pytest.raises(TypeError, match='complex has no JSON form'):
        jsonable({'z': 1j})
    with pytest.raises(TypeError, match='is not a JSON object'):
        json_object([1, 2])


def test_emit_json_adds_only_context_keys(capsys):
    emit_json(_Outer('a', (), {}), file='f.yaml')
    assert json.loads(capsys.readouterr().out) == {'name': 'a', 'inner': [], 'file': 'f.yaml'}
    with pytest.raises(TypeError, match=r"keys \['name'\] twice"):
        emit_json(_Outer('a', (), {}), name='again')


def _plain(obj):
    return json.loads(json.dumps(jsonable(obj)))


FORWARD_KEYS = {'robot', 'arm_name', 'rods', 'arm', 'wafer', 'blade', 'platform', 'naive_wafer', 'naive_platform',
                'naive_wafer_error', 'naive_wafer_error_vector', 'naive_wafer_angle_error', 'gpr', 'station'}


def test_robot_fk_and_ik_json_are_their_records(capsys):
    d = run_json(capsys, 'robot', 'fk', '--rods', '0.25', '0.251', '0.252', '--joints', '0', '1', '-0.5')
    fk = robot_forward(ROBOT, [[0.25, 0.251, 0.252]], [[0.0, 1.0, -0.5]])
    assert d == _plain(fk.record(0)) and set(d) == FORWARD_KEYS
    assert set(d['gpr']) == {'tilt', 'tilt_azimuth', 'twist', 'centre_shift', 'model'}
    assert d['naive_wafer_error'] == float(np.linalg.norm(d['naive_wafer_error_vector']))
    i = run_json(capsys, 'robot', 'ik', '--position', '1.3', '0.6', '0.45', '--tilt', '0.02', '--azimuth', '0.5',
                 '--heading', '0.3')
    sol = solve_stations(ROBOT, Stations.of([[1.3, 0.6, 0.45]], 0.02, 0.5, 0.3))
    assert i == _plain(sol.record(0))
    assert set(i) == FORWARD_KEYS | {'branch', 'naive', 'position_error', 'angle_error'}
    # the naive fields of ik: the naive model's joints against the station, not the answer's own
    assert i['naive_wafer_error'] == sol.naive_wafer_error_norm[0]
    assert i['naive_wafer_error'] != pytest.approx(float(sol.forward.naive_wafer_error_norm[0]), rel=1e-6)
    assert i['station'] == {'position': [1.3, 0.6, 0.45], 'tilt': 0.02, 'azimuth': 0.5, 'heading': 0.3}


def test_robot_teach_json_rows(capsys):
    d = run_json(capsys, 'robot', 'teach', '--rods', '0.25', '0.251', '0.252', '--joints', '0', '1', '-0.5')
    assert set(d) == {'robot', 'reteach', 'stations'}
    assert set(d['stations'][0]) == {'name', 'station', 'naive_station', 'naive_error', 'naive_error_vector'}
    r = run_json(capsys, 'robot', 'teach', '--rods', '0.25', '0.251', '0.252', '--joints', '0', '1', '-0.5', '--naive')
    row = r['stations'][0]
    # moved: the joints re-teach moved more than MOVED_JOINT from the old ones (a nearest arm's posture changed unsaid)
    assert set(row) == {'name', 'intended', 'rods', 'arm', 'avoided_error', 'avoided_error_vector', 'moved'}
    assert row['avoided_error'] == pytest.approx(math.hypot(*row['avoided_error_vector']), rel=1e-15)


def test_mechanism_json_is_the_pose_analysis(capsys):
    d = run_json(capsys, 'mechanism', 'upu3.yaml', '--pose', '0', '0', '0.2', '0', '0', '0')
    mech = load_mechanism('upu3.yaml')
    assert d == _plain(analyse_pose(mech, np.array([0, 0, 0.2, 0, 0, 0.0]))) | {'file': 'upu3.yaml'}
    assert set(d) == {'mechanism', 'type', 'file', 'euler_convention', 'pose', 'pose_variables', 'joints',
                      'inverse_jacobian', 'homogenized_inverse_jacobian', 'characteristic_length',
                      'homogenized_task_jacobian', 'condition_number', 'dexterity', 'singular', 'singularity',
                      'within_limits', 'plane_residuals'}
    assert d['plane_residuals'] is None and set(d['joints'][0]) == {'name', 'type', 'joint_type', 'value', 'unit'}


def test_accuracy_dexterity_sweep_mobility_json_keys(capsys):
    a = run_json(capsys, 'accuracy', 'stewart_alwan.yaml')
    assert set(a) == {'mechanism', 'type', 'variables', 'results', 'warnings'}
    assert len(a['warnings']) == 1 and a['warnings'][0].startswith('pose 1: B = 0.0349066 rad')  # the gimbal lock
    assert set(a['results'][0]) == {'mechanism', 'pose', 'joints', 'joint_errors', 'parameter_errors', 'variables',
                                    'linearized', 'exact', 'difference', 'exact_pose', 'linearized_twist',
                                    'exact_twist', 'condition_number'}
    d = run_json(capsys, 'dexterity', 'upu3.yaml', '--vary', 'z', '0.17', '0.26', '4')
    assert list(d)[-2:] == ['type', 'plot'] and d['variable2'] is None and d['values2'] is None
    assert set(d) == {'mechanism', 'variable', 'values', 'dexterity', 'within_limits', 'singular',
                      'condition_number', 'variable2', 'values2', 'type', 'plot'}
    s = run_json(capsys, 'sweep', '--azimuth-step', '180', '--deg')
    assert set(s) == {'samples', 'passes', 'singular_crossings', 'model', 'height', 'max_tilt', 'max_centre_shift',
                      'max_centre_shift_at', 'max_joint_displacement', 'within_budget', 'max_residual',
                      'max_fit_residual', 'max_fk_iterations', 'max_ik_iterations', 'max_height_error'}
    assert (s['samples'], s['singular_crossings'], set(s['max_centre_shift_at'])) == (42, 2, {'alpha', 'gamma'})
    m = run_json(capsys, 'mobility', '0.5', '0.501', '0.4995', '--dq', '1e-4', '-2e-4', '5e-5')
    res = analyze_mobility([0.5, 0.501, 0.4995])
    assert m['bounds']['for_dq'] == _plain(rod_change(res, [1e-4, -2e-4, 5e-5]))
    assert set(m['bounds']['for_dq']) == {'norm_dx', 'eq4', 'eq5', 'dq', 'norm_dx_full', 'full_solve_refused'}


def test_rod_change_says_why_there_is_no_full_solve():
    res = analyze_mobility([0.4, 0.4, 0.4])
    change = rod_change(res, [0.01, -0.01, 0.0])  # 20 mm across the joint circle tilts far beyond 2 deg
    assert change.norm_dx_full is None and 'tilt' in change.full_solve_refused
    assert change.norm_dx == 0.0  # the singular configuration: the first order vanishes (eq. 3)


def test_rod_change_of_something_else_than_a_mobility_result_names_it():
    with pytest.raises(InputError, match=r"result = None; allowed: a MobilityResult \(analyze_mobility\)"):
        rod_change(None, [1e-4, 0.0, 0.0])  # type: ignore[arg-type]
