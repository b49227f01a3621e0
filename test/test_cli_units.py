"""Millimetres and degrees are input conveniences: an input typed in them is the input typed in metres and radians,
to the bit (a units auditor's review): millimetres from their decimal text, defaults applied in SI, grids made from
SI ends; and refusals of such inputs name the unit the user gave."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from gpr_kinematics.calibration.measurements import parse_measurements
from gpr_kinematics.cli.main import main
from gpr_kinematics.errors import ConfigError, InputError
from gpr_kinematics.inputs.units import metres, to_si
from gpr_kinematics.safety.cell import parse_cell


def test_millimetres_are_the_metres_typed_for_the_same_decimal():
    """437.1 / 1000 is 0.43710000000000004, a quarter of the one-decimal millimetres an ulp off what ``0.4371``
    typed gives; the conversion reads the decimal (its shortest text) and moves its exponent."""
    for k in range(0, 200_001, 7):
        text = f'{k / 100:.2f}'
        assert to_si(float(text), 1e-3) == float(text + 'e-3'), text
    assert metres(437.1, True) == 0.4371 and metres(0.03, True) == 3e-5 and metres(1e-5, True) == 1e-8
    grid = metres(np.array([[729.068, 1106.218], [-0.0, np.inf]]), True)
    assert grid.tolist() == [[0.729068, 1.106218], [-0.0, math.inf]]


def test_the_command_line_reads_decimal_millimetres_as_typed_metres(capsys):
    assert main(['ik', '--height', '437.1', '--tilt', '0', '--azimuth', '0', '--mm', '--json']) == 0
    in_mm = json.loads(capsys.readouterr().out)
    assert main(['ik', '--height', '0.4371', '--tilt', '0', '--azimuth', '0', '--json']) == 0
    assert json.loads(capsys.readouterr().out) == in_mm and in_mm['achieved']['position'][2] == 0.4371


def _chamber(units, size, position=(1.0, 0.0, 0.5)):
    return {'format': 'gpr_cell', 'version': 1, 'frame': 'world', 'units': units,
            'obstacles': [{'name': 'pm', 'position': list(position), 'chamber': {'size': size}}]}


def test_a_chambers_defaults_are_applied_in_si():
    """The default wall, slit and front were written in the file's unit and converted back: in millimetres the back
    wall stood at 0.225 m where metres put it at 0.22499999999999998, the side walls at 2.8e-17 instead of 0."""
    for mm in range(300, 900, 7):
        size = [mm, 500, 250]
        in_mm = parse_cell(_chamber({'length': 'mm'}, size, (1000, 0, 500)))
        in_m = parse_cell(_chamber({'length': 'm'}, [v / 1000 for v in size]))
        for a, b in zip(in_mm.obstacles, in_m.obstacles, strict=True):
            assert a.name == b.name and a.size == b.size and np.array_equal(a.position, b.position), (mm, a.name)


def test_a_cells_angle_refusal_names_its_range_in_the_files_degrees():
    """A tilt of 400 in a cell in degrees was allowed '-6.28319 to 6.28319 rad after conversion', where its azimuth
    and rpy say '[-360, 360] deg': the range in the file's degrees."""
    data = _chamber({'angle': 'deg'}, [0.5, 0.5, 0.25])
    data['obstacles'][0]['tilt'] = 400
    with pytest.raises(ConfigError, match=r'tilt = 400 is invalid; allowed: a finite number in deg, -360 to 360 deg$'):
        parse_cell(data)


def test_a_dexterity_grid_in_millimetres_is_the_grid_in_metres(capsys):
    """The grid was made in mm and converted (0.19999999999999998 for 0.2), and its dexterity differed."""
    base = ['dexterity', 'upu3.yaml', '--json']
    assert main([*base, '--vary', 'z', '0.1', '0.3', '21']) == 0
    in_m = json.loads(capsys.readouterr().out)
    assert main([*base, '--vary', 'z', '100', '300', '21', '--mm']) == 0
    assert json.loads(capsys.readouterr().out) == in_m


def test_a_sigma_refusal_shows_the_si_value_and_says_it_was_converted():
    text = '# units: mm deg\nq1,q2,q3,x,y,z,qx,qy,qz,qw,sigma_position\n300,300,300,0,0,300,0,0,0,1,102\n'
    with pytest.raises(InputError, match=r'column sigma_position: 0\.102 m \(converted from mm\) is outside '
                                         r'\[1e-09, 0\.1\] m$'):
        parse_measurements(text, 'm.csv')


@pytest.mark.parametrize('header, hint', [('# units: mm\nq1,q2,q3,x,y,z,qx,qy,qz,qw', False),
                                          ('q1 [mm],q2 [mm],q3 [mm],x,y,z,qx,qy,qz,qw', False),
                                          ('q1,q2,q3,x,y,z,qx,qy,qz,qw', True)])
def test_the_millimetres_hint_only_where_the_rods_are_in_metres(capsys, tmp_path, header, hint):
    """A rod of 803 mm in a file that declares millimetres was told to declare them."""
    scale = 1e-3 if hint else 1.0      # the other rows in the file's unit
    rows = '\n'.join(f'{803 if i == 0 else 300 * scale},{(300 + i) * scale},{300 * scale},0,0,{300 * scale},0,0,0,1'
                     for i in range(12))
    path = tmp_path / 'm.csv'
    path.write_text(f'{header}\n{rows}\n')
    assert main(['calibrate', str(path), '--output', str(tmp_path / 'c.yaml')]) == 2
    err = capsys.readouterr().err
    assert 'is outside the stroke [0, 0.508] m' in err and ('millimetres?' in err) == hint, err


@pytest.mark.parametrize('argv, message', [(['--tilt-step', '-1', '--deg'], '--tilt-step = -1 deg'),
                                           (['--azimuth-step', '0'], '--azimuth-step = 0 rad'),
                                           (['--max-tilt', '-2', '--deg'], '--max-tilt = -2 deg'),
                                           # inf was "more than --max-tilt" or "not a finite number" by the option
                                           (['--tilt-step', 'inf', '--deg'], '--tilt-step = inf deg'),
                                           (['--azimuth-step', 'inf'], '--azimuth-step = inf rad'),
                                           (['--tilt-step', 'nan'], '--tilt-step = nan rad')])
def test_a_sweeps_angle_refusal_names_the_option_as_typed(capsys, argv, message):
    assert main(['sweep', *argv]) == 2
    assert capsys.readouterr().err == f'gpr sweep: error: {message}; allowed: a positive finite angle\n'


def test_no_millimetres_hint_below_the_stroke(capsys, tmp_path):
    """A rod 1 nm below the stroke's start was told 'millimetres? declare # units: mm': only a rod above the stroke
    can be one in millimetres."""
    rows = '\n'.join(f'{-1e-9 if i == 0 else 0.3},{0.3 + i * 1e-3},0.3,0,0,0.3,0,0,0,1' for i in range(12))
    path = tmp_path / 'm.csv'
    path.write_text(f'q1,q2,q3,x,y,z,qx,qy,qz,qw\n{rows}\n')
    assert main(['calibrate', str(path), '--output', str(tmp_path / 'c.yaml')]) == 2
    err = capsys.readouterr().err
    assert 'is outside the stroke [0, 0.508] m' in err and 'millimetres?' not in err, err


@pytest.mark.parametrize('argv, warning', [
    (['fk', '0.5', '0.503', '0.498'], 'gpr fk: warning: q = 0.5 0.503 0.498 mm (under --mm): metres typed under --mm? '
                                      '(as metres 0.5 0.503 0.498 m)\n'),
    (['ik', '--height', '0.5', '--tilt', '0', '--azimuth', '0'],
     'gpr ik: warning: --height = 0.5 mm (under --mm): metres typed under --mm? (as metres 0.5 m)\n'),
    (['fk', '0', '0', '0'], ''), (['fk', '250', '250.5', '251'], ''), (['ik', '--height', '300', '--tilt', '0',
                                                                         '--azimuth', '0'], '')])
def test_metres_typed_under_mm_are_warned_and_taken_as_typed(capsys, argv, warning):
    """``gpr fk 0.5 0.503 0.498 --mm`` ran on rods of half a millimetre without a word (``gpr robot ik`` hints the
    same slip): taken as typed (the input is valid), with the question on stderr; the bottom of the stroke (0 0 0)
    and lengths of a millimetre or more without."""
    assert main([*argv, '--mm', '--json']) == 0
    out, err = capsys.readouterr()
    assert err == warning and json.loads(out)
    if argv[0] == 'fk':
        assert json.loads(out)['q'] == [float(v + 'e-3') for v in argv[1:]]
