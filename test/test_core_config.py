"""Configuration: embedded default, user overrides, validation messages."""
import math

import numpy as np
import pytest
from gpr_kinematics.core import forward
from gpr_kinematics.core.config import GprConfig, default_config, load_config
from gpr_kinematics.errors import ConfigError


def test_embedded_default_values():
    cfg = default_config()
    assert cfg.radius == 0.093218
    assert cfg.rod_azimuths == pytest.approx((0.0, 2 * math.pi / 3, 4 * math.pi / 3), abs=1e-15)
    assert (cfg.stroke_min, cfg.stroke_max) == (0.0, 0.508)
    assert cfg.tilt_limit == pytest.approx(math.radians(2.0), abs=1e-17)
    assert cfg.imperfection_budget == 0.0005
    assert cfg.model == 'radial'
    assert cfg.characteristic_length == cfg.radius  # null in the file means the radius
    assert cfg.weighting == 'characteristic'


def test_user_file_overrides_subset(tmp_path):
    f = tmp_path / 'my.yaml'
    f.write_text('radius: 0.1\nmodel: polar\n')
    cfg = load_config(f)
    assert cfg.radius == 0.1 and cfg.model == 'polar'
    assert cfg.characteristic_length == 0.1  # follows the new radius
    assert cfg.stroke_max == 0.508  # untouched keys keep the default


def test_replace_and_round_trip():
    cfg = default_config().replace(tilt_limit=0.02, model='offset')
    assert cfg.tilt_limit == 0.02 and cfg.model == 'offset'
    assert GprConfig.from_mapping(cfg.to_dict()) == cfg


@pytest.mark.parametrize('text, key, allowed', [
    ('radius: -1', 'radius', 'metres, 1e-4 <= radius <= 10'),
    ('radius: .nan', 'radius', 'radius'),
    ("radius: '0.1'", 'radius', 'metres'),
    ('stroke_max: 20', 'stroke_max', '<= 10'),
    ('tilt_limit: 0', 'tilt_limit', '1e-6 <= tilt_limit'),
    # below the least but above 0: named with the least (was '0 < tilt_limit', which it is)
    ('tilt_limit: 5.0e-7', 'tilt_limit', 'radians, 1e-6 <= tilt_limit <= 0.261799387 (15 deg)'),
    ('imperfection_budget: 1.0', 'imperfection_budget', '<= 0.01'),
    ('imperfection_budget: 5.0e-10', 'imperfection_budget', 'metres, 1e-9 <= imperfection_budget <= 0.01'),
    ('model: elastic', 'model', 'radial or polar or offset'),
    ('model: stiff', 'model', 'radial or polar or offset or compliant'),
    ('weighting: heavy', 'weighting', 'characteristic or unweighted'),
    ('max_iterations: 0', 'max_iterations', 'integer from 1 to 100'),
    ('max_iterations: 2.5', 'max_iterations', 'integer'),
    ('tolerance: 1.0', 'tolerance', '1e-16 <= tolerance'),
    ('rod_azimuths: [0, 1]', 'rod_azimuths', 'a list of 3'),
    ('characteristic_length: -0.1', 'characteristic_length', '1e-06 <= characteristic_length <= 100'),
    ('characteristic_length: 5.0e-7', 'characteristic_length',
     'metres, 1e-06 <= characteristic_length <= 100, or null'),
    # the imperfect geometry (test_core_machine)
    ('rod_offsets: [0, 0]', 'rod_offsets', 'a list of 3 lengths in metres, -0.1 <= o_k <= 0.1'),
    ('rod_offsets: [0, 0, 0.5]', 'rod_offsets', '-0.1 <= o_k <= 0.1'),
    ("rod_offsets: [0, '0', 0]", 'rod_offsets', 'a list of 3 lengths'),
    ('rod_directions: [[0.1, 0], [0, 0], [0, 0]]', 'rod_directions', '|u_x|, |u_y| <= 0.05'),
    ('rod_directions: [0, 0, 0]', 'rod_directions', 'a list of 3 pairs'),
    ('rod_positions: [[0.1, 0], [0, 0.1]]', 'rod_positions', 'null, or 3 points [x, y] in metres'),
    ('rod_positions: [[0.1, 0, 0], [0, 0.1, 0], [-0.1, 0, 0]]', 'rod_positions', '3 points [x, y]'),
    ('platform_joints: [[.nan, 0], [0, 0.1], [-0.1, 0]]', 'platform_joints', '3 points [x, y]'),
    ('kappa: 0', 'kappa', '1e-6 <= kappa <= 1e6'),
])
def test_invalid_value_names_key_value_and_range(tmp_path, text, key, allowed):
    f = tmp_path / 'bad.yaml'
    f.write_text(text + '\n')
    with pytest.raises(ConfigError) as err:
        load_config(f)
    msg = str(err.value)
    assert key in msg and allowed in msg and str(f) in msg


def test_the_least_characteristic_length_reads_as_the_mechanisms_and_the_ros_parameter_read_it():
    """LEAST_LENGTH's text was written '1e-6' beside it here while the mechanisms derive '1e-06' from it: one text."""
    from gpr_kinematics.core.config import LEAST_LENGTH
    from gpr_kinematics.mechanisms.conditioning import check_characteristic_length
    from gpr_kinematics.ros.specs import config_specs
    with pytest.raises(ConfigError) as core:
        default_config().replace(characteristic_length=5e-7)
    assert str(core.value) == ('replace(): characteristic_length = 5e-07 is invalid; allowed: metres, 1e-06 <= '
                               'characteristic_length <= 100, or null for the radius')
    with pytest.raises(ConfigError) as mech:
        check_characteristic_length(5e-7, 'm.yaml: characteristic_length')
    assert 'allowed: a length from 1e-06 to 1e+06 m' in str(mech.value) and LEAST_LENGTH == 1e-6
    spec = next(s for s in config_specs() if s.name == 'characteristic_length')
    assert spec.constraint_text().endswith('0 means the radius, else at least 1e-06')


def test_unknown_key_lists_allowed_keys(tmp_path):
    f = tmp_path / 'bad.yaml'
    f.write_text('raduis: 0.1\n')
    with pytest.raises(ConfigError, match=r'unknown key\(s\) raduis; allowed keys: .*radius'):
        load_config(f)


def test_cross_field_checks(tmp_path):
    with pytest.raises(ConfigError, match='stroke_min'):
        load_config(overrides={'stroke_min': 0.4, 'stroke_max': 0.3})
    with pytest.raises(ConfigError, match='10 deg apart'):
        load_config(overrides={'rod_azimuths': [0.0, 0.01, 3.0]})


def test_malformed_and_missing_files(tmp_path):
    f = tmp_path / 'broken.yaml'
    f.write_text('radius: [1\n')
    with pytest.raises(ConfigError, match='not valid YAML'):
        load_config(f)
    f.write_text('- 1\n- 2\n')
    with pytest.raises(ConfigError, match='expected a mapping'):
        load_config(f)
    with pytest.raises(ConfigError, match='cannot read config file'):
        load_config(tmp_path / 'missing.yaml')


@pytest.mark.parametrize('config', ['x', 5, {'radius': 0.1}])
def test_a_config_that_is_not_one_is_named(config):
    """forward(q, config='x') was a bare AttributeError deep in the kernels."""
    from gpr_kinematics.core import forward
    from gpr_kinematics.errors import InputError

    with pytest.raises(InputError, match=r'config = .* is not a GprConfig; allowed: a configuration of load_config'):
        forward([0.3, 0.3, 0.3], config=config)


@pytest.mark.parametrize('text', ['', '# only a comment\n', '---\n'])
def test_an_empty_geometry_file_is_refused_not_read_as_the_defaults(tmp_path, text):
    """``gpr fk --config empty.yaml`` computed with the defaults: a truncated or wrong file passed as valid. An
    explicit ``{}`` still says "the defaults as they are"."""
    path = tmp_path / 'g.yaml'
    path.write_text(text)
    with pytest.raises(ConfigError, match=r'g\.yaml: the geometry file is empty \(no YAML document\); allowed: a'):
        load_config(path)
    path.write_text('{}\n')
    assert load_config(path) == load_config()


@pytest.mark.parametrize('key, least, most', [
    ('radius', 1e-4, 10.0), ('stroke_min', -10.0, None), ('stroke_max', None, 10.0),
    ('tilt_limit', 1e-6, math.radians(15.0)), ('imperfection_budget', 1e-9, 0.01),
    ('characteristic_length', 1e-6, 100.0), ('tolerance', 1e-16, 1e-6), ('max_iterations', 1, 100),
    ('rod_offsets', -0.1, 0.1), ('rod_directions', -0.05, 0.05), ('kappa', 1e-6, 1e6),
])
def test_the_ends_of_every_documented_range_are_taken_and_a_step_beyond_refused(key, least, most):
    """Each range's ends as its allowed text states them (``1 to 100``, ``|u_x|, |u_y| <= 0.05``, ...) are valid
    values; a value 1 % (or 1) beyond an end is refused by name."""
    def value(v):
        if key == 'rod_offsets':
            return [v, 0.0, 0.0]
        if key == 'rod_directions':
            return [[v, v], [0.0, 0.0], [0.0, 0.0]]
        return v

    for end, outward in ((least, -1), (most, 1)):
        if end is None:
            continue
        cfg = load_config(overrides={key: value(end)})
        got = getattr(cfg, key)
        assert (got[0][0] if key == 'rod_directions' else got[0] if isinstance(got, tuple) else got) == end
        beyond = end + outward if key == 'max_iterations' else end + outward * 0.01 * abs(end)
        with pytest.raises(ConfigError, match=rf'overrides: {key} = .* is invalid; allowed'):
            load_config(overrides={key: value(beyond)})


def test_the_tilt_limits_bound_is_stated_to_the_digits_it_holds():
    """The largest tilt_limit is 15 deg, 0.26179938779... rad: the message said 0.2618, which it refused; it states
    0.261799387 now, which is taken, and the next value up in its digits is refused."""
    assert load_config(overrides={'tilt_limit': 0.261799387}).tilt_limit == 0.261799387
    with pytest.raises(ConfigError, match=r'tilt_limit = 0.261799388 is invalid; allowed: radians, 1e-6 <= tilt_limit '
                       r'<= 0.261799387 \(15 deg\)$'):
        load_config(overrides={'tilt_limit': 0.261799388})


def test_the_dataclass_defaults_are_the_embedded_file():
    """``GprConfig()`` (the nominal machine of the doctests, the URDF and ``from_mapping``) is the machine of the
    embedded config/gpr.yaml: 2 deg tilt limit, 0.508 m stroke, radius 0.093218 m, and every other value."""
    assert GprConfig() == default_config()
    assert GprConfig().tilt_limit == pytest.approx(math.radians(2.0), abs=1e-17)


@pytest.mark.parametrize('fields, words', [
    # a tolerance of 1 m returned the naive pose without a word; the others were taken as given
    (dict(tolerance=1.0), r'GprConfig: tolerance = 1.0 is invalid; allowed: metres, 1e-16 <= tolerance <= 1e-6'),
    (dict(radius=-1.0), r'GprConfig: radius = -1.0 is invalid; allowed: metres, 1e-4 <= radius <= 10'),
    (dict(tilt_limit=3.0), r'tilt_limit = 3.0 is invalid; allowed: radians, 1e-6 <= tilt_limit <= 0.261799387 '
                           r'\(15 deg\)'),
    (dict(max_iterations=10 ** 6), r'max_iterations = 1000000 is invalid; allowed: an integer from 1 to 100'),
    (dict(imperfection_budget=-1.0), r'imperfection_budget = -1.0 is invalid'),
    (dict(model='polar', weighting='foo'), r"weighting = 'foo' is invalid; allowed: characteristic or unweighted"),
    (dict(model='rigid'), r"model = 'rigid' is invalid; allowed: radial or polar or offset or compliant"),
    (dict(radius='0.1'), r"radius = '0.1' is invalid"),   # TypeError before
    (dict(kappa=[1.0, 2.0]), r'kappa = \[1.0, 2.0\] is invalid; allowed: one number or a list of 3'),
    (dict(characteristic_length=np.array([0.1, 0.2])), r'characteristic_length = array\(\[0.1, 0.2\]\) is invalid'),
])
def test_a_config_built_in_code_is_checked_as_a_file_is(fields, words):
    """``GprConfig(...)`` checked only how values relate (stroke order, triangles); the ranges, names and types were
    the file reader's and ``replace``'s alone."""
    with pytest.raises(ConfigError, match=words):
        GprConfig(**fields)


def test_a_config_built_in_code_takes_what_a_file_takes():
    """A scalar ``kappa`` for all three (TypeError before), numpy scalars and arrays (``replace(radius=
    np.float32(0.1))`` was refused as out of range), and the default following the radius."""
    c = GprConfig(model='compliant', kappa=5.0)
    assert c.kappa == (5.0, 5.0, 5.0)
    q = [0.5, 0.503, 0.5]
    assert forward(q, config=c).tilt == forward(q, config=GprConfig().replace(model='compliant', kappa=5.0)).tilt
    assert GprConfig().replace(radius=np.float32(0.1)).radius == float(np.float32(0.1))
    assert GprConfig().replace(max_iterations=np.int64(10)).max_iterations == 10
    assert GprConfig(rod_offsets=np.array([1e-4, 0.0, -1e-4])).rod_offsets == (1e-4, 0.0, -1e-4)
    assert GprConfig().characteristic_length == GprConfig().radius
    assert GprConfig(radius=0.1).characteristic_length == 0.1
    assert GprConfig(radius=0.1, characteristic_length=0.2).characteristic_length == 0.2
    assert GprConfig() == load_config().replace(**{k: v for k, v in GprConfig().to_dict().items()})


def test_numpy_integers_count_as_numbers():
    assert GprConfig(kappa=np.int64(1000)).kappa == (1000.0, 1000.0, 1000.0)
    assert GprConfig().replace(max_iterations=np.int32(5)).max_iterations == 5

