"""Tolerance tables (gpr_kinematics.calibration.tolerances): units, distributions and their moments, binding to a
model's parameters, and every malformed table refused with the key named."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from calibration_reference import ReferenceModel
from gpr_kinematics.calibration.core_model import CoreModel
from gpr_kinematics.calibration.tolerances import Tolerance, load_tolerances, parse_tolerances
from gpr_kinematics.core.config import load_config
from gpr_kinematics.errors import ConfigError
from gpr_kinematics.inputs.resources import config_path


def test_shipped_example_binds_to_the_core_model():
    table = load_tolerances(config_path('calibration/tolerances_example.yaml'))
    ps = CoreModel(load_config()).parameters
    tols = dict(zip(ps.names, table.bind(ps), strict=True))
    assert tols['rod2_y'] == Tolerance(-3e-5, 3e-5, 'uniform', ps.values(ps.nominal)[ps.index('rod2_y')])
    assert tols['rod3_offset'].high == 5e-5 and tols['joint1_x'].high == 3e-5
    assert tols['rod1_ux'].distribution == 'normal' and tols['rod1_ux'].std == pytest.approx(2e-4 / 3)
    k = tols['kappa2']                                  # the file's kappa 1000; the machine's in [0.5, 2]
    assert (k.nominal, k.transform, k.distribution) == (1000.0, 'anisotropy', 'log-uniform')
    assert k.bounds == pytest.approx((-1 / 3 - 999 / 1001, 1 / 3 - 999 / 1001), rel=1e-12)
    assert table.rod_length.high == 2e-6 and table.joint_clearance == (2e-6, 2e-6, 2e-6)
    assert (table.sigma_position, table.sigma_angle) == (3e-6, 2e-5)


def test_units_names_over_keys_and_ranges():
    table = parse_tolerances({'units': {'length': 'mm', 'angle': 'deg'},
                              'parameters': {'rod_offsets': {'tolerance': 0.05},
                                             'offset2': {'tolerance': 0.01, 'distribution': 'normal'},
                                             'rod_directions': {'tolerance': 0.01},
                                             'kappa': {'range': [0.5, 2.0], 'distribution': 'log-uniform'}},
                              'joint_clearance': [0.001, 0.002, 0.003],
                              'measurement_noise': {'position': 0.003, 'angle': 0.001}}, 't.yaml')
    tols = table.bind(ReferenceModel().parameters)
    assert tols[6].high == pytest.approx(5e-5) and tols[7].high == pytest.approx(1e-5)
    assert tols[7].distribution == 'normal' and tols[8].distribution == 'uniform'
    assert tols[9].high == pytest.approx(math.radians(0.01))
    assert (tols[21].low, tols[21].high) == (-0.5, 1.0)           # kappa nominal 1: the range as deviations
    assert tols[0] is None and tols[15] is None
    np.testing.assert_allclose(table.joint_clearance, [1e-6, 2e-6, 3e-6])
    assert table.sigma_position == pytest.approx(3e-6) and table.sigma_angle == pytest.approx(math.radians(0.001))


@pytest.mark.parametrize('tol', [Tolerance(-2.0, 2.0), Tolerance(-1.0, 3.0), Tolerance(-3.0, 3.0, 'normal'),
                                 Tolerance(-0.5, 1.0, 'log-uniform', 1.0),
                                 Tolerance(-0.5, 1.0, 'log-uniform', 1.0, 'anisotropy'),
                                 Tolerance(-999.5, -998.0, 'uniform', 1000.0, 'anisotropy'),
                                 Tolerance(-2.0, 7.0, 'log-uniform', 3.0, 'anisotropy')])
def test_moments_match_samples(tol):
    """The moments (closed forms; Gauss-Legendre for a transformed deviation) against 400,000 samples, which stay
    within the bounds (of the anisotropy, for a stiffness ratio)."""
    x = tol.sample(np.random.default_rng(0), (400_000,))
    assert x.mean() == pytest.approx(tol.mean, abs=0.01 * tol.std)
    assert x.std() == pytest.approx(tol.std, rel=0.01)
    if tol.distribution != 'normal':
        lo, hi = tol.bounds
        assert lo <= x.min() and x.max() <= hi and tol.centre == pytest.approx(0.5 * (lo + hi))
    if tol.transform:                                   # an anisotropy: deviations of (kappa - 1) / (kappa + 1)
        kappa = tol.nominal + np.array([tol.low, tol.high])
        u0 = (tol.nominal - 1) / (tol.nominal + 1)
        assert tol.bounds == pytest.approx(tuple((kappa - 1) / (kappa + 1) - u0), rel=1e-12)


@pytest.mark.parametrize('data, pattern', [
    ([1, 2], r't\.yaml: expected a mapping'),
    ({'parameter': {}}, r"t\.yaml: unknown key\(s\) parameter; allowed keys: joint_clearance"),
    ({'units': {'length': 'inch'}}, r"units: length 'inch', angle 'rad'; allowed: length m or mm"),
    ({'units': {'length': ['mm']}}, r"units: length \['mm'\], angle 'rad'; allowed: length m or mm"),
    ({'parameters': {'radius': 1e-5}}, r'parameters: radius: expected a mapping such as \{tolerance'),
    ({'parameters': {'radius': {'tol': 1e-5}}}, r"parameters: radius: unknown key\(s\) tol"),
    ({'parameters': {'radius': {}}}, r'give exactly one of tolerance .* or range'),
    ({'parameters': {'radius': {'tolerance': 1e-5, 'range': [0, 1]}}}, r'give exactly one of tolerance'),
    ({'parameters': {'radius': {'tolerance': -1e-5}}}, r'radius: tolerance = -1e-05; allowed: a finite number >= 0'),
    ({'parameters': {'radius': {'tolerance': 1e-5, 'distribution': 'cauchy'}}},
     r"distribution 'cauchy'; allowed: uniform, normal, log-uniform"),
    ({'parameters': {'radius': {'tolerance': 1e-5, 'distribution': 'log-uniform'}}}, r'log-uniform needs a range'),
    ({'parameters': {'kappa': {'range': [2, 1]}}}, r'range \[2, 1\]; allowed: low < high'),
    ({'parameters': {'kappa': {'range': [1]}}}, r'range = \[1\]; allowed: \[low, high\]'),
    ({'parameters': {'kappa': {'range': [1, 2], 'distribution': 'normal'}}}, r'normal needs a tolerance'),
    ({'rod_length': {'range': [0, 1e-6]}}, r'rod_length: give a tolerance'),
    ({'rod_length': {'tolerance': 1.0}}, r'rod_length: tolerance 1 m; allowed: at most 0\.01 m'),
    # a NaN names its quantity's bound, as a number beyond it is refused (it named 'magnitude at most 1e+06')
    ({'rod_length': {'tolerance': float('nan')}},
     r'rod_length: tolerance = nan; allowed: at most 0\.01 m$'),
    ({'joint_clearance': [0, float('inf'), 0]}, r'joint_clearance = inf; allowed: at most 0\.01 m$'),
    ({'measurement_noise': {'position': float('nan'), 'angle': 1e-5}},
     r'measurement_noise: position = nan; allowed: a standard deviation from 1e-09 to 0.1 m$'),
    ({'joint_clearance': [1e-6, 1e-6]}, r'joint_clearance: one value or a list of 3'),
    ({'joint_clearance': 0.5}, r'joint_clearance: 0\.5 m; allowed: at most 0\.01 m$'),
    # a table in mm or deg: the value named as the file gives it and the bound in both units (it said 0.05 m)
    ({'units': {'length': 'mm'}, 'joint_clearance': [0, 50, 1]},
     r'^t\.yaml: joint_clearance: 50 mm \(0\.05 m\); allowed: at most 0\.01 m \(10 mm\)$'),
    ({'units': {'length': 'mm'}, 'rod_length': {'tolerance': 50}},
     r'^t\.yaml: rod_length: tolerance 50 mm \(0\.05 m\); allowed: at most 0\.01 m \(10 mm\)$'),
    ({'units': {'length': 'mm'}, 'measurement_noise': {'position': 300, 'angle': 1e-5}},
     r'^t\.yaml: measurement_noise: position = 300 mm \(0\.3 m\); allowed: a standard deviation from 1e-09 to 0\.1 m '
     r'\(1e-06 to 100 mm\)$'),
    ({'measurement_noise': {'position': 0, 'angle': 1e-5}}, r'measurement_noise: position = 0; allowed: a finite '
                                                             r'number > 0'),
    ({'measurement_noise': {'position': 1e-6}}, r'measurement_noise: angle = None'),
    # the sigmas a measurement file's rows may have: 1e6 m passed gpr accuracy, and gpr calibrate named no file
    ({'measurement_noise': {'position': 1e6, 'angle': 1e-5}}, r't.yaml: measurement_noise: position = 1e\+06 m; '
                                                              r'allowed: a standard deviation from 1e-09 to 0.1 m$'),
    ({'units': {'angle': 'deg'}, 'measurement_noise': {'position': 1e-6, 'angle': 1e-300}},
     r't.yaml: measurement_noise: angle = 1e-300 deg \(1\.74533e-302 rad\); allowed: a standard deviation from 1e-09 '
     r'to 0\.1 rad \(5\.73e-08 to 5\.729 deg\)$'),
])
def test_malformed_tables_refused(data, pattern):
    with pytest.raises(ConfigError, match=pattern):
        parse_tolerances(data, 't.yaml')


@pytest.mark.parametrize('entry, pattern', [
    ({'rod_offsets': {'tolerance': float('nan')}},
     r'rod_offsets: tolerance = nan; allowed: at most 0\.01 m$'),
    ({'rod_offsets': {'tolerance': 0.5}}, r'rod_offsets: tolerance 0\.5 m; allowed: at most 0\.01 m$'),
    ({'rod1_ux': {'tolerance': 1e300}}, r'rod1_ux: tolerance = 1e\+300; allowed: at most 0\.1 rad$'),
    ({'rod1_ux': {'tolerance': 0.5}}, r'rod1_ux: tolerance 0\.5 rad; allowed: at most 0\.1 rad$'),
    ({'rod2_offset': {'tolerance': '5um'}},
     r"rod2_offset: tolerance = '5um' \(no number\); allowed: at most 0\.01 m$"),
    ({'rod2_offset': {'tolerance': '3.0e-5'}},   # it said 'allowed: at most 0.01 m' of 3e-5 in quotes
     r"tolerance = '3\.0e-5' \(YAML read it as text: write the number without quotes\); allowed: at most 0\.01 m$"),
    ({'rod1_x': {'range': [0.1, float('nan')]}}, r'rod1_x: range = \[0\.1, nan\]; allowed: values within 0\.01 m '
                                                 r"of the nominal \(a key's range"),
    ({'rod1_x': {'range': [0.1, 0.105]}}, r'rod1_x: range .* reaches .*; allowed: values within 0\.01 m of the '
                                          r'nominal'),
    ({'kappa': {'range': [1, float('inf')]}}, r'kappa: range = \[1, inf\]; allowed: 1e-06 to 1e\+06$'),
])
def test_a_nan_names_its_units_bound(entry, pattern):
    # one rule per quantity: a value that is no number names the bound a number beyond it meets (the parameter's
    # unit); it named 'a finite number of magnitude at most 1e+06', a number then refused at 0.01 m
    ps = CoreModel(load_config()).parameters
    with pytest.raises(ConfigError, match=pattern):
        parse_tolerances({'parameters': entry}, 't.yaml').bind(ps)


@pytest.mark.parametrize('data, pattern', [
    # a whole key's NaN hidden by its parameters' own entries (bind never reads it) passed as valid
    ({'parameters': {'rod_offsets': {'tolerance': float('nan')}, 'rod1_offset': {'tolerance': 5e-5},
                     'rod2_offset': {'tolerance': 5e-5}, 'rod3_offset': {'tolerance': 5e-5}}},
     r'rod_offsets: tolerance = nan; allowed: at most 0\.01 m$'),
    ({'parameters': {'kappa': {'range': ['abc', 2.0], 'distribution': 'log-uniform'}}},
     r"kappa: range = \['abc', 2\.0\]; allowed: 1e-06 to 1e\+06$"),
    ({'parameters': {'kappa': {'tolerance': float('nan')}}}, r'kappa: tolerance = nan; allowed: at most 1e\+06$'),
    ({'parameters': {'base_rz': {'tolerance': float('nan')}}}, r'base_rz: tolerance = nan; allowed: at most 0\.1 rad$'),
    ({'parameters': {'radius': {'tolerance': '5um'}}},
     r"radius: tolerance = '5um' \(no number\); allowed: at most 0\.01 m for a length, 0\.1 rad for an angle"),
    ({'rod_length': {'range': [float('nan'), 1.0]}}, r'rod_length: range = \[nan, 1\.0\]; allowed: a tolerance'),
])
def test_a_value_that_is_no_number_is_refused_when_the_table_is_read(data, pattern):
    # also where no model binds the table (gpr calibrate --robot reads only its measurement_noise) or an entry is
    # hidden by others: refused at bind only, both had passed
    with pytest.raises(ConfigError, match=pattern):
        parse_tolerances(data, 't.yaml')


def test_binding_refusals(tmp_path):
    ps = CoreModel(load_config()).parameters
    with pytest.raises(ConfigError, match=r"parameters: unknown parameter 'radius'; this model has rod1_x, "
                                          r'rod1_y.*whole keys: rod_positions, rod_offsets, rod_directions, '
                                          r'platform_joints, kappa'):
        parse_tolerances({'parameters': {'radius': {'tolerance': 1e-5}}}, 't.yaml').bind(ps)
    with pytest.raises(ConfigError, match=r'parameters: rod_offsets: tolerance 0\.5 m; allowed: at most 0\.01 m$'):
        parse_tolerances({'parameters': {'rod_offsets': {'tolerance': 0.5}}}, 't.yaml').bind(ps)
    # in the file's mm or deg: named so, the bound in both (it said 'tolerance 0.05 m; allowed: at most 0.01 m')
    with pytest.raises(ConfigError, match=r'^t\.yaml: parameters: rod_offsets: tolerance 50 mm \(0\.05 m\); allowed: '
                                          r'at most 0\.01 m \(10 mm\)$'):
        parse_tolerances({'units': {'length': 'mm'}, 'parameters': {'rod_offsets': {'tolerance': 50}}},
                         't.yaml').bind(ps)
    with pytest.raises(ConfigError, match=r'^t\.yaml: parameters: rod_directions: tolerance 10 deg \(0\.174533 rad\); '
                                          r'allowed: at most 0\.1 rad \(5\.729 deg\)$'):
        parse_tolerances({'units': {'angle': 'deg'}, 'parameters': {'rod_directions': {'tolerance': 10}}},
                         't.yaml').bind(ps)
    with pytest.raises(ConfigError, match=r'a log-uniform range must be positive'):
        parse_tolerances({'parameters': {'rod1_ux': {'range': [-1e-3, 1e-3], 'distribution': 'log-uniform'}}},
                         't.yaml').bind(ps)
    with pytest.raises(ConfigError, match=r'kappa: a stiffness ratio takes uniform or log-uniform'):
        parse_tolerances({'parameters': {'kappa': {'tolerance': 10, 'distribution': 'normal'}}}, 't.yaml').bind(ps)
    with pytest.raises(ConfigError, match=r'kappa1: \[-1000, 3000\] leaves the range of a stiffness ratio; allowed: '
                                          r'1e-06 to 1e\+06'):
        parse_tolerances({'parameters': {'kappa1': {'tolerance': 2000}}}, 't.yaml').bind(ps)
    bomb = tmp_path / 'bomb.yaml'
    bomb.write_text('a: &a [1, 2]\nb: *a\n')
    with pytest.raises(ConfigError, match=r'bomb\.yaml: line 2: YAML aliases'):
        load_tolerances(bomb)
    with pytest.raises(ConfigError, match=r'is not a regular file'):
        load_tolerances(tmp_path)


def test_a_range_far_from_the_nominal_is_refused_as_a_tolerance_beyond_its_bound():
    """A range gives the values; its ends' deviations from the nominal are bounded as a tolerance is (0.01 m, 0.1
    rad). They were not: ``rod1_offset: {range: [0.05, 0.05001]}`` (5 cm off) passed ``gpr calibrate`` as the bias
    bound of a held parameter and ``rod_positions: {range: [0, 3e-5]}`` (each rod's place about 0.09 m away: a key's
    range applies to each of its parameters) calibrated and planned, the budget failing in its samples' geometry."""
    ps = CoreModel(load_config()).parameters
    x1 = float(ps.values(ps.nominal)[ps.index('rod1_x')])
    near = parse_tolerances({'parameters': {'rod1_offset': {'range': [1e-5, 3e-5]},
                                            'rod1_x': {'range': [x1 - 0.01, x1 + 0.004]}}}, 't.yaml').bind(ps)
    off, x = near[ps.index('rod1_offset')], near[ps.index('rod1_x')]
    assert (off.low, off.high, off.nominal) == (1e-5, 3e-5, 0.0)
    assert off.mean == pytest.approx(2e-5, abs=1e-18) and off.std == pytest.approx(2e-5 / math.sqrt(12), rel=1e-12)
    assert x.low == pytest.approx(-0.01, abs=1e-15) and x.high == pytest.approx(0.004, abs=1e-15)
    for entry, pattern in ((('rod1_offset', [0.05, 0.05001]), r'rod1_offset: range \[0\.05, 0\.05001\] m reaches '
                                                             r'0\.05001 m from the nominal 0 m; allowed: values within '
                                                             r'0\.01 m'),
                           (('rod_positions', [0.0, 3e-5]), rf'rod_positions: range \[0, 3e-05\] m reaches '
                                                            rf'{abs(x1):.6g} m from the nominal {x1:.6g} m'),
                           (('rod2_ux', [0.05, 0.2]), r'rod2_ux: range \[0\.05, 0\.2\] rad reaches 0\.2')):
        with pytest.raises(ConfigError, match=pattern):
            parse_tolerances({'parameters': {entry[0]: {'range': entry[1]}}}, 't.yaml').bind(ps)


def test_a_range_at_the_bound_written_in_mm_is_not_refused_for_its_rounding():
    """A range reaching exactly 10 mm from the nominal, or 20 mm wide, is within the bounds (0.01 m, as a tolerance of
    10 mm is). Written in mm about rod2_x's nominal (-46.609 mm, -0.04660899999999998 m as the geometry computes it)
    its ends' deviations round to 0.01 m and 1e-17 (the width to 0.02 and 4e-18): both were refused ('reaches 0.01 m
    from the nominal ...; allowed: values within 0.01 m', 'is wider than 0.02'). 1e-8 m beyond is still refused."""
    ps = CoreModel(load_config()).parameters
    x2 = float(ps.values(ps.nominal)[ps.index('rod2_x')])
    mm = round(x2 * 1e3, 6)
    assert mm == -46.609
    for lo, hi, low, high in ((mm - 10.0, mm + 10.0, -0.01, 0.01), (mm, mm + 10.0, 0.0, 0.01),
                              (mm - 10.0, mm, -0.01, 0.0)):
        t = parse_tolerances({'units': {'length': 'mm'}, 'parameters': {'rod2_x': {'range': [lo, hi]}}},
                             't.yaml').bind(ps)[ps.index('rod2_x')]
        assert t.low == pytest.approx(low, abs=1e-15) and t.high == pytest.approx(high, abs=1e-15)
    for lo, hi, pattern in ((mm, mm + 10.00001, r'reaches 0\.01000001 m from the nominal -0\.046609 m; allowed: '
                                                r'values within 0\.01 m'),
                            (mm - 10.00001, mm + 10.00001, r'range \[-0\.056609, -0\.036609\] m is 0\.02000002 m '
                                                          r'wide; allowed: at most 0\.02 m \(20 mm\)$')):
        with pytest.raises(ConfigError, match=pattern):
            parse_tolerances({'units': {'length': 'mm'}, 'parameters': {'rod2_x': {'range': [lo, hi]}}},
                             't.yaml').bind(ps)


def test_lists_where_mappings_belong_are_refused():
    """units: [] and parameters: [] were read as no units and no parameters."""
    import pytest
    from gpr_kinematics.calibration.tolerances import parse_tolerances
    from gpr_kinematics.errors import ConfigError

    with pytest.raises(ConfigError, match=r'units: expected \{length: m\|mm, angle: rad\|deg\}'):
        parse_tolerances({'units': []})
    with pytest.raises(ConfigError, match=r'parameters: expected a mapping of parameter names to tolerances'):
        parse_tolerances({'parameters': []})


def test_a_tolerance_beyond_the_geometrys_limit_is_refused_naming_the_entry(capsys, tmp_path, monkeypatch):
    """``rod_directions: {tolerance: 0.1}`` is within the table's 0.1 rad but a rod direction's limit is 0.05: the
    budget drew rods of 0.09 and was refused as 'per-row geometry, row 0' (no table entry named); a range reaching
    past it, or a tolerance about a nominal 0.04, likewise. Now bind refuses them naming the key, the value and the
    limit, for gpr accuracy and gpr calibrate --tolerances alike; 0.05 itself, at the limit, is taken."""
    from gpr_kinematics.cli.main import main
    from gpr_kinematics.core.config import GprConfig
    ps = CoreModel(load_config()).parameters
    rule = ('rod_directions: a list of 3 pairs [u_x, u_y], |u_x|, |u_y| <= 0.05 (rods within about 4 deg of the base '
            'z axis)')
    for entry, name, reach, nominal in (({'rod_directions': {'tolerance': 0.1}}, 'rod1_ux', '[-0.1, 0.1]', 0),
                                        ({'rod2_uy': {'range': [0.02, 0.06]}}, 'rod2_uy', '[0.02, 0.06]', 0)):
        key, given = next(iter(entry)), entry[next(iter(entry))]
        what = f'tolerance {given["tolerance"]:g} rad' if 'tolerance' in given else f'range {reach} rad'
        with pytest.raises(ConfigError) as exc:
            parse_tolerances({'parameters': entry}, 't.yaml').bind(ps)
        assert str(exc.value) == (f"t.yaml: parameters: {key}: {what} takes {name} to {reach} (nominal {nominal}); "
                                  f"allowed: within the geometry's limits [-0.05, 0.05] of {name} ({rule})")
    tilted = CoreModel(GprConfig(rod_directions=((0.04, 0.0), (0.0, 0.0), (0.0, 0.0)))).parameters
    with pytest.raises(ConfigError, match=r'^t\.yaml: parameters: rod1_ux: tolerance 0\.02 rad takes rod1_ux to '
                                          r'\[0\.02, 0\.06\] \(nominal 0\.04\); allowed: within the geometry'):
        parse_tolerances({'parameters': {'rod1_ux': {'tolerance': 0.02}}}, 't.yaml').bind(tilted)
    at = parse_tolerances({'parameters': {'rod_directions': {'tolerance': 0.05}}}, 't.yaml').bind(ps)
    assert at[ps.index('rod3_uy')].bounds == (-0.05, 0.05)
    from gpr_kinematics.calibration.monte_carlo import limits
    lower, upper = limits(ps)       # where the Monte Carlo takes a normal draw's tail beyond the limit
    j, k = ps.index('rod1_ux'), ps.index('kappa1')
    assert (lower[j], upper[j], lower[ps.index('rod1_offset')], upper[ps.index('joint2_y')]) == (-0.05, 0.05, -0.1, 10)
    assert (lower[k], upper[k]) == (ps.bounds[0][k], ps.bounds[1][k]) == (-999999 / 1000001, 999999 / 1000001)
    monkeypatch.setattr('gpr_kinematics.cli.progress.AFTER', float('inf'))
    bad = str(tmp_path / 'bad.yaml')
    Path(bad).write_text('parameters:\n  rod_directions: {tolerance: 0.1}\n')
    line = (f"{bad}: parameters: rod_directions: tolerance 0.1 rad takes rod1_ux to [-0.1, 0.1] (nominal 0); allowed: "
            f"within the geometry's limits [-0.05, 0.05] of rod1_ux ({rule})")
    for argv in (['accuracy', 'gpr.yaml', '--tolerances', bad, '--pose', '0', '0', '0.5', '0.0349', '0', '0'],
                 ['calibrate', '--plan', '8', '--tolerances', bad]):
        status = main(argv)
        out, err = capsys.readouterr()
        assert (status, out, err) == (2, '', f'gpr {argv[0]}: error: {line}\n'), argv


def test_a_normal_draw_past_the_geometrys_limit_is_taken_at_the_limit(capsys, tmp_path, monkeypatch):
    """``rod_directions: {tolerance: 0.045, distribution: normal}``: its 3 sigma within the limit 0.05, but 0.08 % of
    the draws lie beyond 0.05 (3.33 sigma) and the Monte Carlo was refused as 'per-row geometry, row 303'; they are
    taken at the limit (outside the worst case's bounds, as a calibrated kappa's beyond 1e6)."""
    from gpr_kinematics.cli.main import main
    monkeypatch.setattr('gpr_kinematics.cli.progress.AFTER', float('inf'))
    path = tmp_path / 'normal.yaml'
    path.write_text('parameters:\n  rod_directions: {tolerance: 0.045, distribution: normal}\n')
    status = main(['accuracy', 'gpr.yaml', '--tolerances', str(path), '--pose', '0', '0', '0.5', '0.0349', '0', '0',
                   '--samples', '2000', '--json'])
    out, err = capsys.readouterr()
    assert status == 0, err
    assert 'per-row geometry' not in err and '"monte_carlo' in out
    # the clip's bounds: each rod direction's geometry limit, +-0.05; a kappa's range (kappa = 1e6) as before
    from gpr_kinematics.calibration.monte_carlo import limits
    params = CoreModel(load_config()).parameters
    lower, upper = limits(params)
    bounds = {p.name: (lo, hi) for p, lo, hi in zip(params, lower, upper, strict=True)}
    assert all(bounds[f'rod{k}_{c}'] == (-0.05, 0.05) for k in (1, 2, 3) for c in ('ux', 'uy'))
    assert bounds['kappa1'] == tuple(params.bounds[i][params.names.index('kappa1')] for i in (0, 1))


def test_a_drawn_machine_the_geometry_refuses_names_the_table(capsys, tmp_path, monkeypatch):
    """``rod_positions: {tolerance: 0.8 mm}`` is within every parameter's limits, but sample 116 of 3,000 moved two
    rods 1.7 mm farther apart than their joints (1 % of the 161.5 mm side allowed), and a range ``rod1_x: [0.101,
    0.103]`` centres the rods' triangle 7.7 mm wider: both budgets were refused as 'per-row geometry, row N', naming
    no table. Now the table is named, with the sample (or the centre) and the geometry's reason; a small tolerance
    passes."""
    from gpr_kinematics.calibration.budget import accuracy_budget
    from gpr_kinematics.cli.main import main
    model = CoreModel(load_config())
    Q = [[0.3, 0.3, 0.3]]
    table = parse_tolerances({'parameters': {'rod_positions': {'tolerance': 8e-4}}}, 'wide.yaml')
    with pytest.raises(ConfigError) as exc:
        accuracy_budget(model, Q, table, samples=3000, seed=0)
    sides = 'side 3-1 of the joint triangle is 0.161458 m, the rods are 0.163153 m apart'
    assert str(exc.value) == (f'wide.yaml: Monte Carlo sample 116 of these tolerances is a machine the geometry '
                              f'refuses ({sides}; allowed: within 1% of each other); allowed: tolerances whose every '
                              'draw is a valid geometry (smaller ones of rod_positions and platform_joints: the rods '
                              "and the joints keep triangles alike)")
    small = parse_tolerances({'parameters': {'rod_positions': {'tolerance': 1e-4}}}, 'small.yaml')
    assert np.all(np.isfinite(accuracy_budget(model, Q, small, samples=3000, seed=0).mc_rms['platform_horizontal'] > 0))
    centred = parse_tolerances({'parameters': {'rod1_x': {'range': [0.101, 0.103]}}}, 'off.yaml')
    with pytest.raises(ConfigError, match=r"^off\.yaml: the centre of these tolerances \(each parameter at its mean\) "
                                          r'is a machine the geometry refuses \(side 1-2 of the joint triangle is '
                                          r'0\.161458 m, the rods are 0\.169121 m apart; allowed: within 1% of each '
                                          r'other\); allowed: tolerances whose'):
        accuracy_budget(model, Q, centred, samples=10, seed=0)
    monkeypatch.setattr('gpr_kinematics.cli.progress.AFTER', float('inf'))
    path = tmp_path / 'wide.yaml'
    path.write_text('parameters:\n  rod_positions: {tolerance: 0.0008}\n')
    status = main(['accuracy', 'gpr.yaml', '--tolerances', str(path), '--pose', '0', '0', '0.3', '0', '0', '0',
                   '--samples', '3000', '--seed', '0'])
    out, err = capsys.readouterr()
    assert (status, out) == (2, '') and err.startswith(f'gpr accuracy: error: {path}: Monte Carlo sample '), err


def test_a_plan_from_tolerances_whose_centre_the_geometry_refuses_names_the_table(capsys, tmp_path, monkeypatch):
    """``rod1_x: {range: [0.101, 0.103]}`` centres the rods' triangle 7.7 mm wider than the joints' (1 % of a side
    allowed): a measurement plan made there (``gpr calibrate --plan``, ``gpr accuracy --calibration-plan``) was
    refused as 'per-row geometry, row 0', naming no table; now the table and its centre are named."""
    from gpr_kinematics.cli.main import main
    monkeypatch.setattr('gpr_kinematics.cli.progress.AFTER', float('inf'))
    path = tmp_path / 'off.yaml'
    path.write_text('parameters:\n  rod1_x: {range: [0.101, 0.103]}\n')
    line = (f'{path}: the centre of these tolerances (each parameter at its mean) is a machine the geometry refuses '
            '(side 1-2 of the joint triangle is 0.161458 m, the rods are 0.169121 m apart; allowed: within 1% of each '
            'other); allowed: tolerances whose every draw is a valid geometry (smaller ones of rod_positions and '
            'platform_joints: the rods and the joints keep triangles alike)')
    for argv in (['calibrate', '--plan', '8', '--tolerances', str(path)],
                 ['accuracy', 'gpr.yaml', '--tolerances', str(path), '--pose', '0', '0', '0.3', '0', '0', '0',
                  '--calibration-plan', '6', '--samples', '100']):
        status = main(argv)
        out, err = capsys.readouterr()
        assert (status, out, err) == (2, '', f'gpr {argv[0]}: error: {line}\n'), argv


def test_a_zero_tolerance_is_held_at_its_nominal_value_in_calibration():
    """A tolerance of 0 means exact in the budget; as a calibration prior it was read as no entry, and the parameter
    fitted with the model's default scale (0.1 mm for a rod offset), while 1e-12 held it. Now 0 fixes it at its
    nominal value (held, it was described as a direction the poses cannot see: test_calibration_identification)."""
    from gpr_kinematics.calibration.identification import identify
    from gpr_kinematics.calibration.measurements import read_measurements
    from gpr_kinematics.calibration.tolerances import EXACT_PRIOR, prior_of

    model = CoreModel(load_config())
    params = model.parameters
    table = parse_tolerances({'parameters': {'rod_offsets': {'tolerance': 0}, 'rod1_x': {'tolerance': 3e-5}}})
    prior = prior_of(table, params)
    offsets = [params.names.index(f'rod{k}_offset') for k in (1, 2, 3)]
    np.testing.assert_array_equal(prior[offsets], EXACT_PRIOR * params.scale[offsets])
    assert prior[params.names.index('rod1_x')] == pytest.approx(3e-5 / math.sqrt(3))   # uniform in [-t, t]
    assert np.isnan(prior[params.names.index('rod2_x')])                              # no entry: the model's scale
    res = identify(model, read_measurements(config_path('calibration/synthetic_measurements.csv')), prior=prior)
    assert [res.status[j] for j in offsets] == ['fixed'] * 3
    assert np.all(res.estimate[offsets] == params.nominal[offsets])
