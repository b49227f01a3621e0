"""``gpr mechanism``, ``gpr accuracy`` and ``gpr dexterity``: JSON output and one-line errors (exit 2)."""
from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
import yaml
from gpr_kinematics.cli.main import main
from gpr_kinematics.inputs.resources import config_path
from gpr_kinematics.mechanisms import load_mechanism
from gpr_kinematics.mechanisms.pose_analysis import analyse_pose


def run(capsys, *argv: str) -> tuple[int, str, str]:
    try:
        code = main(list(argv))
    except SystemExit as exc:          # argparse usage errors (already one line, status 2)
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def test_mechanism_json_asymmetric_gsp(capsys):
    code, out, err = run(capsys, 'mechanism', str(config_path('mechanisms/gsp_d1d2d3d4a1a1.yaml')),
                         '--pose', '7', '-8', '124', '2', '5', '-5', '--mm', '--deg', '--json')
    assert code == 0, err
    data = json.loads(out)
    assert [j['type'] for j in data['joints']] == ['D1', 'D2', 'D3', 'D4', 'A1', 'A1']
    vals = [j['value'] for j in data['joints']]
    np.testing.assert_allclose(np.array(vals[:3]) * 1e3, [133.007, 87.5579, 130.427], atol=6e-4)
    np.testing.assert_allclose(np.degrees(vals[4:]), [34.0845, 44.0236], atol=6e-5)
    assert [j['unit'] for j in data['joints']] == ['m'] * 4 + ['rad'] * 2
    J = np.array(data['inverse_jacobian'])
    H = np.array(data['homogenized_inverse_jacobian'])
    assert J.shape == H.shape == (6, 6)
    np.testing.assert_allclose(H[:4, 3:], J[:4, 3:] / 0.16)
    assert data['condition_number'] > 1 and data['singular'] is False
    sv = np.linalg.svd(np.array(data['homogenized_task_jacobian']), compute_uv=False)
    assert data['condition_number'] == pytest.approx(sv[0] / sv[-1], rel=1e-9)
    np.testing.assert_allclose(data['homogenized_task_jacobian'], H)     # six DOF: the task is the twist
    assert data['pose']['z'] == pytest.approx(0.124)


def test_mechanism_text_and_help(capsys):
    code, out, _ = run(capsys, 'mechanism', 'gsp_d3_6.yaml', '--pose', '0.01', '-0.01', '0.138', '5', '-5', '-10',
                       '--deg')
    assert code == 0 and '0.143908863 m' in out and 'condition number' in out
    code, helptext, _ = run(capsys, 'mechanism', '--help')
    assert code == 0
    assert "from_euler('xyz', [A, B, C])" in helptext and 'ZXZ' in helptext
    assert 'program' not in helptext.split('--pose')[0]
    code, helptext, _ = run(capsys, 'accuracy', '--help')  # its FILE may also be a program (with --tolerances)
    assert code == 0 and 'with --tolerances also a platform or robot program' in ' '.join(helptext.split())


def test_mechanism_text_prints_zero_without_a_minus_sign(capsys):
    """gpr mechanism gpr.yaml --pose 0 0 0.5 0 0 0 printed tilt_x = -0 and Jacobian entries -0.000000 (-2e-17); the
    other values as before, and --json keeps the numbers as computed (-0.0 too)."""
    pose = ('--pose', '0', '0', '0.5', '0', '0', '0')
    code, out, err = run(capsys, 'mechanism', 'gpr.yaml', *pose)
    assert code == 0, err
    lines = out.splitlines()
    assert lines[0].endswith(', z = 0.5, tilt_x = 0, tilt_y = 0, twist = 0')
    assert lines[5] == '  ' + ' '.join(f'{v:11.6f}' for v in (0.0, 0.0, 1.0, 0.0, -0.093218, 0.0))
    assert not re.search(r'-0(?:\.0+)?(?![.0-9e])', out)   # no zero with a minus sign
    code, out, _ = run(capsys, 'mechanism', 'gpr.yaml', *pose, '--json')
    data = json.loads(out)
    # the numbers as analyse_pose computes them (that entry's sign and size are the machine's BLAS: -2e-17, 7.7e-17)
    mine = analyse_pose(load_mechanism(config_path('mechanisms/gpr.yaml')), [0.0, 0.0, 0.5, 0.0, 0.0, 0.0])
    assert code == 0 and math.copysign(1.0, data['pose']['tilt_x']) == math.copysign(1.0, mine.pose['tilt_x'])
    assert data['inverse_jacobian'] == mine.inverse_jacobian.tolist()


def test_tripod_and_upu_json(capsys):
    code, out, _ = run(capsys, 'mechanism', 'tripod_3rps.yaml', '--pose', '0', '0', '0.1', '0.1', '0.2', '0',
                       '--json')
    data = json.loads(out)
    assert code == 0 and max(abs(r) for r in data['plane_residuals']) < 1e-15
    assert data['pose']['phi'] == pytest.approx(math.atan(math.sin(0.2) * math.sin(0.1) /
                                                          (math.cos(0.2) + math.cos(0.1))))
    code, out, _ = run(capsys, 'mechanism', 'upu3.yaml', '--pose', '0', '0', '200', '0', '0', '0', '--mm', '--json')
    data = json.loads(out)
    assert code == 0 and data['singularity'] is None and len(data['joints']) == 3


def test_singular_pose_reported(capsys):
    code, out, _ = run(capsys, 'mechanism', 'stewart_alwan.yaml', '--pose', '0', '0', '0', '0.1', '0', '0', '--json')
    data = json.loads(out)
    assert code == 0 and data['singular'] is True
    assert data['condition_number'] == 'inf' or data['condition_number'] > 1e9


def test_accuracy_json_trajectory(capsys):
    code, out, err = run(capsys, 'accuracy', 'stewart_alwan.yaml', '--json')
    assert code == 0, err
    data = json.loads(out)
    assert len(data['results']) == 6
    first = data['results'][0]
    assert first['variables'] == ['x', 'y', 'z', 'A', 'B', 'C']
    assert abs(first['exact']['x'] - first['linearized']['x']) < 1e-5
    np.testing.assert_allclose(first['joint_errors'], [0.00012, 0.00045, 0.00026, 0.00032, 0.00028, 0.00041])


def test_accuracy_warns_on_stderr_next_to_the_gimbal_lock(capsys):
    """Point 1 of Alwan's trajectory (theta = 2 deg) is 0.0349 rad from the Z-X-Z lock: its psi, phi deviations
    (-0.055, 0.056 rad for a rotation of 2.6 mrad) were printed without a word."""
    for extra in ((), ('--json',)):
        code, out, err = run(capsys, 'accuracy', 'stewart_alwan.yaml', *extra)
        assert code == 0 and err.count('\n') == 1
        assert err.startswith('gpr accuracy: warning: pose 1: B = 0.0349066 rad is 0.0349 rad from the gimbal lock of '
                              'the ZXZ Euler angles (warned within 0.1 rad)')
        assert 'read the rotation vector of the rigid motion (rx ry rz, base frame) instead' in err
    assert json.loads(out)['warnings'] == [err.removeprefix('gpr accuracy: warning: ').rstrip('\n')]
    code, out, err = run(capsys, 'accuracy', 'stewart_alwan.yaml', '--pose', '0.34', '-0.17', '1.83', '-7', '10', '2.2',
                         '--deg')
    assert code == 0 and err == '' and 'linearized' in out


def test_accuracy_gpr_with_imperfections(capsys):
    code, out, err = run(capsys, 'accuracy', 'gpr.yaml', '--pose', '0', '0', '300', '0.01', '0', '0',
                         '--errors', '0.1', '0', '-0.1', '--mm', '--parameter-error', 'joint_imperfections',
                         *(['0.05'] * 9), '--json')
    assert code == 0, err
    res = json.loads(out)['results'][0]
    assert res['variables'] == ['z', 'tilt_x', 'tilt_y']
    np.testing.assert_allclose(res['joint_errors'], [1e-4, 0, -1e-4])
    # Second order: errors of ~0.1 mm over a 93 mm joint circle leave ~0.1 um between the two.
    assert max(abs(v) for v in res['difference'].values()) < 5e-7
    assert max(abs(v) for v in res['linearized'].values()) > 1e-5
    # --errors repeated adds up (the last option's values alone were kept: 'takes 3 values; got 2')
    code, out, err = run(capsys, 'accuracy', 'gpr.yaml', '--pose', '0', '0', '300', '0.01', '0', '0', '--errors',
                         '0.1', '--errors', '0', '-0.1', '--mm', '--json')
    assert code == 0, err
    np.testing.assert_allclose(json.loads(out)['results'][0]['joint_errors'], [1e-4, 0, -1e-4])


def test_dexterity_plot_and_json(capsys, tmp_path):
    png = tmp_path / 'd.png'
    code, out, err = run(capsys, 'dexterity', 'upu3.yaml', '--vary', 'z', '170', '260', '10', '--mm', '--plot',
                         str(png), '--json')
    assert code == 0, err
    data = json.loads(out)
    assert data['variable'] == 'z' and len(data['values']) == 10
    assert data['values'][0] == pytest.approx(0.17) and all(np.diff(data['dexterity']) < 0)
    assert png.read_bytes()[:4] == b'\x89PNG'
    code, out, _ = run(capsys, 'dexterity', 'gpr.yaml')
    assert code == 0 and 'tilt_x' in out


@pytest.mark.parametrize('argv, message', [
    (['mechanism', 'upu3.yaml', '--pose', '0', '0', '0.3', '0', '0', '0'], 'is outside its limits [0.17, 0.27] m\n'),
    # 200 mm typed as metres: legs of 200 m, said without a hint (the GPR's, the robot's and accuracy's give one)
    (['mechanism', 'upu3.yaml', '--pose', '0', '0', '200', '0', '0', '0'],
     'joint l1 = 200 m is outside its limits [0.17, 0.27] m (millimetres given as metres?)\n'),
    (['mechanism', 'upu3.yaml', '--pose', '0', '0', '0.2', '0.1', '0', '0'], 'only translates'),
    (['mechanism', 'nosuch.yaml', '--pose', '0', '0', '0.2', '0', '0', '0'], 'not found'),
    (['mechanism', 'gpr.yaml', '--pose', '0', '0', '0.3', '5', '0', '0', '--deg'], 'tilt limit'),
    (['mechanism', 'upu3.yaml', '--pose', '0', '0', 'nan', '0', '0', '0'], 'not a finite number'),
    (['accuracy', 'upu3.yaml', '--pose', '0', '0', '0.2', '0', '0', '0', '--errors', '1', '2'],
     '--errors has 2 values in all; allowed: 3 (l1, l2, l3), one per joint (the values of every --errors joined'),
    (['accuracy', 'upu3.yaml', '--pose', '0', '0', '0.2', '0', '0', '0', '--parameter-error', 'foo', '1'],
     "unknown parameter 'foo'"),
    (['accuracy', 'upu3.yaml'], 'give --pose'),
    (['dexterity', 'upu3.yaml', '--vary', 'A', '0', '1', '5'], "cannot vary 'A'"),
    (['dexterity', 'upu3.yaml', '--vary', 'z', '1', '0', '5'], 'need MIN < MAX'),
    (['dexterity', 'upu3.yaml', '--vary', 'z', '0.1', '0.2', '1000000000'],
     "COUNT = 1000000000; allowed: an integer from 2 to 50000"),
    (['dexterity', 'upu3.yaml', '--vary', 'z', '0.1', '0.2', '3', '--vary2', 'x', '-0.1', '0.1', '20000'],
     'dexterity on a 3 x 20000 grid: 60000 poses; allowed: at most 50000 per map'),
    (['dexterity', 'upu3.yaml', '--vary', 'z', '-1e308', '1e308', '3'], 'need MIN < MAX, both finite'),
    (['dexterity', 'gpr.yaml', '--pose', '0', '0', '5', '0', '0', '0'],   # the widened stroke, quoted as the GPR's
     "the map reaches beyond even the domain it computes in (the limits widened, the poses beyond them computed there "
     "and marked; the numbers below are the domain's): height = 5 m puts a rod outside the stroke [-0.508, 1.016] m"),
    (['dexterity', 'upu3.yaml', '--vary2', 'z', '0.17', '0.26', '10'],   # it said "got z twice"; z was given once
     '--vary2 z: the first varied variable is z too (the default without --vary)'),
    (['dexterity', 'upu3.yaml', '--vary', 'z', '0.17', '0.26', '3', '--vary2', 'z', '0.17', '0.26', '3'],
     'the two varied pose variables must differ; got z twice'),
    (['dexterity', 'upu3.yaml', '--vary', 'z', '0.1', '1e308', '3'], 'both finite and of magnitude at most 1e+06'),
    (['dexterity', 'upu3.yaml', '--plot', 'out.unknownext'], "unknown type .unknownext; allowed: .png, .pdf, .svg"),
    (['mechanism', 'upu3.yaml', '--pose', '1e200', '0', '0.2', '0', '0', '0'], '--pose: x = 1e+200 m; allowed'),
    (['mechanism', 'typo_dir/upu3.yaml', '--pose', '0', '0', '0.2', '0', '0', '0'],
     "'typo_dir/upu3.yaml' not found (a path with a folder is read as given"),
    (['mechanism', '', '--pose', '0', '0', '0.2', '0', '0', '0'], 'mechanism file path is empty'),
    # a bare name too long for the file system was an OSError traceback
    (['mechanism', 'a' * 5000, '--pose', '0', '0', '0.2', '0', '0', '0'],
     "... (5000 characters) not found, here nor among the packaged files"),
    # an angle beyond 1e6 rad keeps no digits modulo 2 pi; it passed as valid
    (['accuracy', 'stewart_alwan.yaml', '--pose', '0', '0', '0.5', '1e308', '0', '0'],
     '--pose: A = 1e+308 rad; allowed: |x|, |y|, |z| <= 1e+06 m and |A|, |B|, |C| <= 1e+06 rad'),
    (['mechanism', 'gpr.yaml', '--pose', '0', '0', '0.3', '0', '1e300', '0', '--deg'], '--pose: B = 1.74533e+298 rad'),
    # the second silently replaced the first
    (['accuracy', 'gpr.yaml', '--pose', '0', '0', '0.5', '0', '0', '0', '--parameter-error', 'joint_imperfections',
      *['1e-4'] * 9, '--parameter-error', 'joint_imperfections', *['0'] * 9],
     '--parameter-error joint_imperfections is given twice; allowed: each parameter once'),
    # a NaN among them was refused as 'must have 18 finite values (shape (6, 3), SI); got shape (6, 3)'
    (['accuracy', 'stewart_alwan.yaml', '--pose', '0', '0', '1', '0', '0', '0', '--parameter-error', 'A_i',
      *['0'] * 3, 'nan', *['0'] * 14],
     'error of parameter A_i: value 4 of 18 is nan, not a finite number; allowed: 18 finite values (shape (6, 3), SI)'),
    # a number beyond the largest float named as typed, not as inf
    (['accuracy', 'upu3.yaml', '--pose', '0', '0', '0.2', '0', '0', '0', '--errors', '1e400', '0', '0'],
     "'1e400' is not a finite number (beyond the largest float, 1.8e308)"),
    # a point's error of 1e6 m passed as a result (z 9e3 m), and 0.05 with --mm left off as 50 mm
    (['accuracy', 'gpr.yaml', '--pose', '0', '0', '0.5', '0.0349', '0', '0', '--parameter-error', 'joint_imperfections',
      '0.05', *['0'] * 8],
     '--parameter-error joint_imperfections: value 1 = 0.05 m is beyond 0.01 m; allowed: errors of at most 0.01 m, as '
     "a tolerance table's (millimetres given as metres? give --mm)"),
    (['accuracy', 'stewart_alwan.yaml', '--pose', '0', '0', '1', '0', '0', '0', '--mm', '--parameter-error', 'A_i',
      *['0'] * 17, '-10.5'],
     "--parameter-error A_i: value 18 = -10.5 mm is beyond 0.01 m; allowed: errors of at most 0.01 m, as a tolerance "
     "table's"),
])
def test_bad_input_exits_2_with_one_line(capsys, argv, message):
    code, out, err = run(capsys, *argv)
    assert code == 2
    assert message in err and err.count('\n') == 1 and 'Traceback' not in err


def test_bad_files_exit_2(capsys, tmp_path):
    data = yaml.safe_load(config_path('mechanisms/gsp_d3_6.yaml').read_text())
    cases = {
        'unknown.yaml': lambda d: d['constraints'][0].update(type='D9'),
        'degenerate.yaml': lambda d: d['constraints'][0].update(A_j=list(d['constraints'][0]['A_i'])),
        'count.yaml': lambda d: d['constraints'][0].update(B_j=[0, 0, 0]),
    }
    expected = {'unknown.yaml': "type = 'D9' is not a constraint type",
                'degenerate.yaml': 'degenerate base line K',
                'count.yaml': 'a D3 constraint takes the points A_i, A_j, B_i; got the extra point(s) B_j'}
    for name, mutate in cases.items():
        d = yaml.safe_load(yaml.safe_dump(data))
        mutate(d)
        path = tmp_path / name
        path.write_text(yaml.safe_dump(d))
        code, _, err = run(capsys, 'mechanism', str(path), '--pose', '0', '0', '0.13', '0', '0', '0')
        assert code == 2 and str(path) in err and expected[name] in err and err.count('\n') == 1


def test_singular_pose_asked_for_an_inverse_exits_2(capsys, tmp_path):
    # An A1 constraint at theta = 0 has no inverse-Jacobian row; accuracy needs the inverse.
    legs = [{'type': 'D1', 'A_i': [math.cos(a), math.sin(a), 0], 'B_i': [0.5 * math.cos(a), 0.5 * math.sin(a), 0]}
            for a in np.linspace(0, 2 * math.pi, 5, endpoint=False)]
    legs.append({'type': 'A1', 'A_i': [0, 0, 0], 'A_j': [0, 0, 1], 'B_i': [0, 0, 0], 'B_j': [0, 0, 1]})
    path = tmp_path / 'a1.yaml'
    path.write_text(yaml.safe_dump({'type': 'gsp', 'constraints': [
        {k: (list(map(float, v)) if k != 'type' else v) for k, v in c.items()} for c in legs]}))
    code, _, err = run(capsys, 'mechanism', str(path), '--pose', '0', '0', '1', '0', '0', '0')
    assert code == 2 and 'not defined' in err and 'a1_6 (A1): the lines K and L are parallel (theta = 0 or pi)' in err
    # D4 lines parallel: the error was 'd4 = inf m is outside its limits [0, inf] m'
    legs[-1] = {'type': 'D4', 'A_i': [0, 0, 0], 'A_j': [0, 0, 1], 'B_i': [0.1, 0, 0], 'B_j': [0.1, 0, 1]}
    path.write_text(yaml.safe_dump({'type': 'gsp', 'constraints': [
        {k: (list(map(float, v)) if k != 'type' else v) for k, v in c.items()} for c in legs]}))
    for command in ('mechanism', 'accuracy'):
        code, _, err = run(capsys, command, str(path), '--pose', '0', '0', '1', '0', '0', '0')
        assert code == 2 and err.count('\n') == 1 and 'inf' not in err
        assert 'd4_6 (D4): the lines K and L are parallel (R t x s = 0): their distance d = |v x s| is defined' in err
    code, _, err = run(capsys, 'accuracy', 'stewart_alwan.yaml', '--pose', '0', '0', '0', '0.1', '0', '0',
                       '--errors', '0', '0', '0', '0', '0', '1e-4')
    assert code == 2 and 'singular' in err and err.count('\n') == 1


def test_hostile_mechanism_files_and_plot_paths(capsys, tmp_path):
    path = tmp_path / 'list.yaml'
    path.write_text('type: [gpr]\n')   # was a TypeError (an unhashable type) and a traceback
    code, _, err = run(capsys, 'mechanism', str(path), '--pose', '0', '0', '0.2', '0', '0', '0')
    assert code == 2 and "type = ['gpr'] is not a mechanism type" in err and err.count('\n') == 1
    (tmp_path / 'out.png').mkdir()
    code, out, err = run(capsys, 'dexterity', 'upu3.yaml', '--plot', str(tmp_path / 'out.png'))
    assert code == 2 and out == '' and 'out.png exists and is not a regular file (it is a directory)' in err
    assert not (tmp_path / 'out.png.png').exists()
    code, out, _ = run(capsys, 'dexterity', 'upu3.yaml', '--plot', str(tmp_path / 'map.svg'))
    assert code == 0 and f'plot written to {tmp_path / "map.svg"}' in out
    assert (tmp_path / 'map.svg').read_text().lstrip().startswith('<?xml')


def test_mechanism_and_mobility_agree_on_the_singular_configuration(capsys):
    """gpr mechanism said "singular: no" where gpr mobility reports rank 9: one test now (mobility.rigid_rank)."""
    for pose, singular in ((['0', '0', '0.3', '0', '0', '0'], True), (['0', '0', '0.3', '0.01', '0', '0'], False)):
        code, out, _ = run(capsys, 'mechanism', 'gpr.yaml', '--pose', *pose, '--json')
        data = json.loads(out)
        q = [j['value'] for j in data['joints']]
        code2, out2, _ = run(capsys, 'mobility', *map(repr, q), '--json')
        mob = json.loads(out2)
        assert code == code2 == 0 and data['singular'] is mob['singular'] is singular
        assert (data['singularity'] is not None) is singular and mob['rank_dphi_dp'] == (9 if singular else 11)
    code, out, _ = run(capsys, 'mechanism', 'gpr.yaml', '--pose', '0', '0', '0.3', '0', '0', '0')
    assert 'singular: yes (rigid mechanism: rank dPhi/dP = 9, mobility 3' in out


@pytest.mark.parametrize('box', ['x', [], float('inf'), {'q': [0, 1]}])
def test_a_bad_workspace_section_is_refused_by_every_command_reading_the_file(capsys, tmp_path, box):
    """``gpr dexterity`` and ``gpr mechanism`` do not use ``workspace:``, but a file whose box ``gpr workspace``
    refuses is not valid: they took a box of "x" (exit 0)."""
    data = yaml.safe_load(config_path('mechanisms/tripod_3rps.yaml').read_text())
    data['workspace']['box'] = box
    path = tmp_path / 'bad.yaml'
    path.write_text(yaml.safe_dump(data))
    for argv in (['dexterity', str(path)], ['mechanism', str(path), '--pose', '0', '0', '0.1', '0', '0', '0']):
        code, out, err = run(capsys, *argv)
        assert code == 2 and err.count('\n') == 1 and 'workspace.box' in err and 'bad.yaml' in err, (argv, err)
    data['workspace']['box'] = {'z': [0.0, 0.14]}
    path.write_text(yaml.safe_dump(data))
    assert run(capsys, 'dexterity', str(path))[0] == 0


@pytest.mark.parametrize('overrides', [{'model': 'compliant', 'kappa': 2.0}, {'rod_offsets': [0.001, 0.0, 0.0]}])
def test_the_gpr_analyses_take_overrides_its_workspace_model_does_not(capsys, tmp_path, overrides):
    """A GPR file's overrides the workspace model refuses (another virtual-joint model, a calibrated machine's
    geometry) were refused by ``gpr mechanism``, ``dexterity`` and ``accuracy`` too, as the shipped file has a
    ``workspace:`` section they check: they use them now (another centre shift or rod than the nominal radial
    GPR's), while ``gpr workspace`` refuses them and a malformed box is still refused by every command."""
    data = yaml.safe_load(config_path('mechanisms/gpr.yaml').read_text())
    data['overrides'] = overrides
    path = tmp_path / 'over.yaml'
    path.write_text(yaml.safe_dump(data))
    pose = ['--pose', '0', '0', '0.3', '0.01', '0', '0']
    shift = []
    for file in (config_path('mechanisms/gpr.yaml'), path):
        code, out, err = run(capsys, 'mechanism', str(file), *pose, '--json')
        assert code == 0, err
        got = json.loads(out)
        shift.append([got['pose']['x'], *(j['value'] for j in got['joints'])])
    assert 2.3e-6 < shift[0][0] < 2.4e-6   # the nominal radial model's shift, 2.33 um
    assert np.max(np.abs(np.subtract(shift[1], shift[0]))) > 1e-6   # compliant: another shift; offset: another rod
    for argv in (['dexterity', str(path)], ['accuracy', str(path), *pose, '--errors', '1e-5', '0', '-1e-5']):
        code, _, err = run(capsys, *argv)
        assert code == 0, (argv, err)
    code, _, err = run(capsys, 'workspace', str(path), '--delta', '0.01')
    assert code == 2 and err.count('\n') == 1 and 'over.yaml' in err and 'allowed' in err, err
    data['workspace']['box']['z'] = 'x'
    path.write_text(yaml.safe_dump(data))
    code, _, err = run(capsys, 'mechanism', str(path), *pose)
    assert code == 2 and 'workspace.box.z' in err, err


def test_a_joint_error_beyond_a_tolerance_tables_is_refused_with_the_units_hint(capsys):
    """``gpr accuracy gpr.yaml --errors 0.1 0 -0.1`` (the docs' example without ``--mm``) printed an "exact" tilt of
    0.89 rad, 0.3 m one of 1.1 rad with a rod off its stroke: joint errors are bounded as a tolerance table's
    (0.01 m, 0.1 rad; the library too), the refusal hinting at the unit; at the bound they are taken."""
    from gpr_kinematics.errors import InputError
    from gpr_kinematics.mechanisms.accuracy import accuracy_analysis
    pose = ['--pose', '0', '0', '0.3', '0.01', '0', '0']
    code, out, err = run(capsys, 'accuracy', 'gpr.yaml', *pose, '--errors', '0.1', '0', '-0.1')
    assert code == 2 and out == '' and err.count('\n') == 1, err
    assert ('joint error of q1 = 0.1 m is beyond 0.01 m; allowed: errors of at most 0.01 m (0.1 rad for angular '
            "joints), as a tolerance table's (the linearisation means nothing beyond) (millimetres given as metres? "
            'give --mm)') in err, err
    assert run(capsys, 'accuracy', 'gpr.yaml', *pose, '--errors', '0.01', '0', '-0.01')[0] == 0
    gsp = ['accuracy', 'gsp_d1d2d3d4a1a1.yaml', '--pose', '0', '0', '1', '0', '0', '0', '--errors', '0', '0', '0', '0']
    code, _, err = run(capsys, *gsp, '0.2', '0')
    assert code == 2 and 'joint error of theta4 = 0.2 rad is beyond 0.1 rad' in err and 'give --deg)' in err, err
    assert run(capsys, *gsp, '5', '0', '--deg')[0] == 0
    mech = load_mechanism(config_path('mechanisms/gpr.yaml'))
    with pytest.raises(InputError, match=r'error of q2 = -0\.0100001 m \(pose 2\) is beyond 0\.01 m; .*beyond\)$'):
        accuracy_analysis(mech, [[0, 0, 0.3, 0, 0, 0]] * 2, [[0, 0, 0], [0, -0.0100001, 0]])


def test_the_library_names_a_parameter_error_that_is_not_numbers():
    """accuracy_analysis took a parameter error of strings to a ValueError traceback (numpy's conversion)."""
    from gpr_kinematics.errors import InputError
    from gpr_kinematics.mechanisms.accuracy import linearized_deviation
    mech = load_mechanism(config_path('mechanisms/stewart_alwan.yaml'))
    for value, message in ((['a'] * 18, "A_i = ['a', 'a', 'a', 'a', 'a', 'a', 'a', 'a', ...]; allowed: 18 finite"),
                           ([[0.0] * 3] * 5, 'A_i has shape (5, 3); allowed: 18 finite values (shape (6, 3), SI)'),
                           (10**400, 'A_i = <an integer of about 401 digits>; allowed')):
        with pytest.raises(InputError, match=re.escape(message)):
            linearized_deviation(mech, [0, 0, 1, 0, 0, 0], parameter_errors={'A_i': value})


def test_the_dexterity_plot_marks_the_least_and_the_singular_poses_in_si_units(capsys):
    """The plot's x axis read 'z' (no unit) and the GPR's curve at 0.707 lay on the top frame, 'joints outside
    limits' was in the legend with no such pose, and neither the least dexterity nor the singular tilt 0 (named by
    the mechanism, dexterity 0.707) was marked: the axes are in m and rad, the top 10 % above the largest value, the
    least within the limits marked at its pose and named with the text's numbers, the singular poses marked (and
    said on the text's row)."""
    import matplotlib.pyplot as plt
    from gpr_kinematics.mechanisms.dexterity import dexterity_figure, dexterity_grid, dexterity_sweep
    gpr = load_mechanism('gpr.yaml')
    dmap = dexterity_sweep(gpr, [0, 0, 0.3, 0, 0, 0], 'tilt_x', np.linspace(-0.02, 0.02, 5))
    fig = dexterity_figure(dmap)
    ax = fig.axes[0]
    lines = {line.get_label(): line for line in ax.lines}
    assert ax.get_xlabel() == 'tilt_x [rad]' and ax.get_ylim()[1] == pytest.approx(1.1 * dmap.dexterity.max())
    assert 'outside the limits (joints or pose)' not in lines and list(lines['singular'].get_xdata()) == [0.0]
    least = next(line for name, line in lines.items() if name.startswith('least'))
    k = int(np.argmin(dmap.dexterity))
    assert (least.get_xdata()[0], least.get_ydata()[0]) == (dmap.values[k], dmap.dexterity[k])
    assert least.get_label() == f'least within limits {dmap.dexterity[k]:.6f}\nat tilt_x = 0 rad'
    plt.close(fig)
    code, out, _ = run(capsys, 'dexterity', 'gpr.yaml', '--vary', 'tilt_x', '-0.02', '0.02', '5')
    assert code == 0 and [row.endswith('(singular)') for row in out.splitlines()[1:]] == [False, False, True, False,
                                                                                          False]
    upu = load_mechanism('upu3.yaml')
    dmap = dexterity_grid(upu, [0, 0, 0.2, 0, 0, 0], 'x', np.linspace(-0.05, 0.05, 5), 'z', np.linspace(0.17, 0.26, 4))
    fig = dexterity_figure(dmap)
    ax = fig.axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ('z [m]', 'x [m]')
    assert fig.axes[1].get_ylabel() == 'dexterity within the limits\n(white: outside them)'
    inside = np.where(dmap.within_limits, dmap.dexterity, np.inf)
    i, j = np.unravel_index(np.argmin(inside), inside.shape)
    (least,) = ax.lines
    assert (least.get_xdata()[0], least.get_ydata()[0]) == (dmap.values2[j], dmap.values[i])
    assert least.get_label().startswith(f'least within limits {inside[i, j]:.4f} at z = 0.26 m, x = ')
    plt.close(fig)


def test_a_dexterity_map_of_rounding_differences_is_one_colour_without_an_offset_over_its_title():
    """The GPR's map over +-1 mrad of tilt (0.7071067 to 0.7071073) wrote the colour bar's offset '1e-7+7.071e-1'
    over the title and hid the singular pose under the least's marker; a map whose columns differ by 1e-11 was
    drawn in the scale's two ends. The bar's ticks are plain numbers now, the singular pose drawn over the least
    and the colours span at least COLOUR_SPREAD of the largest value."""
    import matplotlib.pyplot as plt
    from gpr_kinematics.mechanisms.dexterity import COLOUR_SPREAD, dexterity_figure, dexterity_grid
    gpr = load_mechanism('gpr.yaml')
    dmap = dexterity_grid(gpr, [0, 0, 0.3, 0, 0, 0], 'tilt_x', np.linspace(-0.001, 0.001, 5), 'tilt_y',
                          np.linspace(-0.001, 0.001, 5))
    fig = dexterity_figure(dmap)
    fig.canvas.draw()
    ax, bar = fig.axes
    assert bar.yaxis.get_offset_text().get_text() == ''
    singular = next(line for line in ax.lines if line.get_label() == 'singular')
    least = next(line for line in ax.lines if line.get_label().startswith('least'))
    assert singular.get_zorder() > least.get_zorder() and list(singular.get_xdata()) == [0.0]
    plt.close(fig)
    dmap = dexterity_grid(gpr, [0, 0, 0.3, 0, 0, 0], 'tilt_x', np.linspace(-0.001, 0.001, 3), 'z',
                          np.array([0.2, 0.2000000001]))
    fig = dexterity_figure(dmap)
    lo, hi = fig.axes[0].collections[0].get_clim()
    top, bottom = float(np.nanmax(dmap.dexterity)), float(np.nanmin(dmap.dexterity))
    assert top - bottom < 0.5 * COLOUR_SPREAD * top   # 2.4e-7 of 0.707 over the tilt, 1e-11 over z
    assert hi - lo == pytest.approx(COLOUR_SPREAD * top, rel=1e-6) and lo < bottom < top < hi
    plt.close(fig)


def test_accuracy_refuses_where_mechanism_calls_the_pose_singular(capsys):
    """One threshold and one dexterity (mechanisms.conditioning): at a dexterity of 2e-10, which `gpr mechanism` and
    docs/mechanisms.md call singular (below 1e-9), `gpr accuracy` had its own 1e-10 and linearised, printing a
    rotation of 3.84 rad where the exact one is 0.05 rad."""
    pose = ['0', '0', '0', '0', '0', '-0.8909522654903852']
    code, out, _ = run(capsys, 'mechanism', 'gsp_d3_6.yaml', '--pose', *pose, '--json')
    data = json.loads(out)
    assert code == 0 and data['singular'] is True and 1e-10 < data['dexterity'] < 1e-9, data['dexterity']
    code, _, err = run(capsys, 'accuracy', 'gsp_d3_6.yaml', '--pose', *pose, '--errors', *['1e-10'] * 6)
    assert code == 2 and err.count('\n') == 1 and 'is singular (inverse condition number' in err, err


@pytest.mark.parametrize('name, top', [('gsp_d1d2d3d4a1a1.yaml', 0.30085623643361625), ('stewart_alwan.yaml', 2.4),
                                       ('upu3.yaml', 0.267975)])
def test_the_default_heights_come_from_length_limits_or_the_mechanism_s_size(capsys, name, top):
    """The GSP's default z ran to 6.28319 m (twice its A1 joints' pi rad), the Stewart platform's to 1.6 m, short of
    the paper's trajectory at 1.80-1.98 m: twice the largest length limit, else the largest distance of two points."""
    code, out, err = run(capsys, 'dexterity', name, '--json')
    assert code == 0, err
    values = json.loads(out)['values']
    assert values[-1] == pytest.approx(top, rel=1e-12) and len(values) == 51


def test_dexterity_json_writes_an_infinite_condition_number_as_inf(capsys):
    """The 3-UPU at z = 0 (coplanar limbs) has an infinite condition number: ``"condition_number": [-1.0, -1.0,
    -1.0]``, then null, where every other number that is not finite is the text "inf" (docs/architecture.md); a
    grid's rows too."""
    code, out, err = run(capsys, 'dexterity', 'upu3.yaml', '--vary', 'x', '-0.05', '0.05', '3', '--json')
    assert code == 0, err
    assert json.loads(out)['condition_number'] == ['inf', 'inf', 'inf']
    code, out, err = run(capsys, 'dexterity', 'upu3.yaml', '--vary', 'x', '-0.05', '0.05', '2', '--vary2', 'z', '0',
                         '0.2', '2', '--json')
    data = json.loads(out)['condition_number']
    assert code == 0 and [row[0] for row in data] == ['inf', 'inf'] and all(c > 1 for c in (data[0][1], data[1][1]))


@pytest.mark.parametrize('command', ['mechanism', 'accuracy'])
def test_a_platform_turned_over_by_degrees_typed_as_radians_is_refused_with_the_hint(capsys, command):
    """Alwan's first pose (section 5, printed in degrees) typed as radians: theta = 2 rad turns the platform over
    (its normal 114.6 deg from the base's), and the legs came out 2.407 ... 2.170 m with exit 0; with --deg the
    paper's first leg, 2.003 m."""
    errors = ['--errors'] + ['0.0001'] * 6 if command == 'accuracy' else []
    pose = ['--pose', '0.66', '-0.35', '1.8', '-5', '2', '1.4']
    code, out, err = run(capsys, command, 'stewart_alwan.yaml', *pose, *errors)
    assert code == 2 and out == ''
    assert err == (f'gpr {command}: error: Gough-Stewart platform (Alwan 2011): --pose A B C = -5 2 1.4 rad turn the '
                   "platform over (its normal 114.6 deg from the base's z axis); allowed: a platform tilted less than "
                   '90 deg (degrees given as radians? give --deg)\n'), err
    code, out, err = run(capsys, 'mechanism', 'stewart_alwan.yaml', *pose, '--deg', '--json')
    assert code == 0 and err == ''
    assert json.loads(out)['joints'][0]['value'] == pytest.approx(2.00325, abs=1e-5)
    # Independently: Z-X-Z of (-5, 2, 1.4) rad puts the platform's z axis at cos(2) below the horizontal
    assert math.degrees(math.acos(math.cos(2.0))) == pytest.approx(114.59, abs=0.01)


def test_a_platform_tilted_far_by_degrees_typed_as_radians_is_warned_and_analysed(capsys):
    """Toz & Kucuk's angles (5, -5, -10) typed as radians tilt the GSP 85.4 deg: analysed (it is a pose), with the
    hint on stderr; as degrees no warning; a tilt of 30 deg typed in radians no warning."""
    code, out, err = run(capsys, 'mechanism', 'gsp_d3_6.yaml', '--pose', '0.01', '-0.01', '0.138', '5', '-5', '-10')
    assert code == 0 and out
    assert err == ('gpr mechanism: warning: --pose A B C = 5 -5 -10 rad tilt the platform 85.38 deg from its base '
                   '(degrees given as radians? give --deg)\n'), err
    R = np.array([[1, 0, 0], [0, math.cos(5), -math.sin(5)], [0, math.sin(5), math.cos(5)]])   # Rx(A)
    R = np.array([[math.cos(-5), 0, math.sin(-5)], [0, 1, 0], [-math.sin(-5), 0, math.cos(-5)]]) @ R   # Ry(B)
    assert math.degrees(math.acos(R[2, 2])) == pytest.approx(85.38, abs=0.005)   # Rz(C) keeps the normal's z
    for pose, deg in ((['5', '-5', '-10'], ['--deg']), (['0.5', '0', '0'], [])):
        code, out, err = run(capsys, 'mechanism', 'gsp_d3_6.yaml', '--pose', '0.01', '-0.01', '0.138', *pose, *deg)
        assert code == 0 and err == '', err


@pytest.mark.parametrize('name, pose, wrong', [
    ('tripod_3rps.yaml', ['5', '5', '0.1', '0.2', '0.3', '1'], 'X Y C = 5, 5, 1'),
    ('tripod_3rps.yaml', ['0', '0', '0.1', '0.2', '0.3', '0.5'], 'C = 0.5'),
    ('gpr.yaml', ['1', '1', '0.3', '0.01', '0', '0.5'], 'X Y C = 1, 1, 0.5')])
def test_pose_values_the_mechanism_sets_given_otherwise_are_refused(capsys, name, pose, wrong):
    """The tripod's X, Y, C (parasitic) and the GPR's (outcomes of its virtual joints) were dropped without a word
    (the tripod analysed at x = 0.00066 m for X = 5); 0 is ignored, the values the mechanism sets are taken back."""
    code, out, err = run(capsys, 'mechanism', name, '--pose', *pose)
    assert code == 2 and out == ''
    assert re.fullmatch(rf'gpr mechanism: error: .*: --pose {wrong} are set by the mechanism from Z A B \(.* at this '
                        r'pose\); allowed: 0 \(ignored\) or those values\n', err), err
    zeroed = ['0' if i in (0, 1, 5) else v for i, v in enumerate(pose)]
    code, out, err = run(capsys, 'mechanism', name, '--pose', *zeroed, '--json')
    assert code == 0 and err == ''
    full = json.loads(out)['pose']
    typed_back = [f'{v:.9g}' for v in full.values()]
    code, out, err = run(capsys, 'mechanism', name, '--pose', *typed_back, '--json')
    assert code == 0 and err == '', err
    assert list(json.loads(out)['pose'].values()) == pytest.approx(list(full.values()), abs=1e-12)
