"""The core CLI stands alone: with only numpy, scipy, PyYAML and the package on the path (an isolated interpreter,
``python -I -S``, no site-packages: no rosbags, matplotlib or ROS), the core subcommands run, and a subcommand
whose optional dependency is missing exits 2 with one line naming it."""
import json
import subprocess
import sys
from pathlib import Path

import numpy
import pytest
import scipy
import yaml

import gpr_kinematics

RUN = 'import sys; sys.path[:0] = [sys.argv.pop(1)]; from gpr_kinematics.cli.main import main; sys.exit(main())'


@pytest.fixture(scope='module')
def core_path(tmp_path_factory):
    """A directory holding links to numpy, scipy, PyYAML (with their bundled libraries) and the package only."""
    root = tmp_path_factory.mktemp('core_only')
    for module in (numpy, scipy, yaml, gpr_kinematics):
        pkg = Path(module.__file__).parent
        for item in [pkg, pkg.with_name(pkg.name + '.libs'), pkg.with_name('_yaml') if module is yaml else None]:
            if item is not None and item.exists():
                (root / item.name).symlink_to(item)
    return root


def gpr(core_path, *argv):
    return subprocess.run([sys.executable, '-I', '-S', '-c', RUN, str(core_path), *argv], capture_output=True,
                          text=True, timeout=120, cwd=core_path)


def test_only_the_core_dependencies_are_importable(core_path):
    probe = ('import sys, importlib.util; sys.path[:0] = [sys.argv[1]]; '
             'print([m for m in ("numpy", "scipy", "yaml", "gpr_kinematics", "rosbags", "matplotlib", "rclpy") '
             'if importlib.util.find_spec(m)])')
    out = subprocess.run([sys.executable, '-I', '-S', '-c', probe, str(core_path)], capture_output=True, text=True,
                         timeout=60)
    assert out.stdout.strip() == "['numpy', 'scipy', 'yaml', 'gpr_kinematics']", out.stderr


@pytest.mark.parametrize('argv, key', [
    (['fk', '0.5', '0.503', '0.498'], 'centre_shift'),
    (['ik', '--height', '0.5', '--tilt', '2', '--azimuth', '0', '--deg'], 'achieved'),
    (['compensate', '--height', '0.4', '--tilt', '1.5', '--azimuth', '40', '--deg', '--tool', '0.3', '0', '0.1'],
     'arm_correction'),
    (['mobility', '0.5', '0.5', '0.5'], 'rank_dphi_dp'),
    (['sweep', '--azimuth-step', '90', '--deg'], 'max_centre_shift'),
    (['mechanism', 'upu3.yaml', '--pose', '0', '0', '0.2', '0', '0', '0'], 'joints'),
    (['mechanism', 'gpr.yaml', '--pose', '0', '0', '0.3', '0.01', '0', '0'], 'inverse_jacobian'),
])
def test_core_subcommands_run_without_optional_packages(core_path, argv, key):
    res = gpr(core_path, *argv, '--json')
    assert res.returncode == 0 and res.stderr == '', res.stderr
    assert key in json.loads(res.stdout)


@pytest.mark.parametrize('argv, package, extra', [
    (['verify', 'some_bag'], 'rosbags', 'bags'),
    (['dexterity', 'upu3.yaml', '--plot', 'out.png'], 'matplotlib', 'plot'),
    (['program', 'check', str(Path(__file__).resolve().parents[1] / 'gpr_kinematics' / 'config' / 'programs'
                              / 'example_cell_program.yaml')], 'fcl', 'safety'),
])
def test_missing_optional_package_is_one_line_and_status_2(core_path, tmp_path, argv, package, extra):
    res = gpr(core_path, *argv)
    assert res.returncode == 2 and res.stdout == ''
    assert res.stderr.count('\n') == 1 and 'Traceback' not in res.stderr
    assert f"optional package '{package}'" in res.stderr and f'gpr_kinematics[{extra}]' in res.stderr, res.stderr


@pytest.mark.slow
def test_help_lists_every_subcommand_and_marks_the_unavailable_ones(core_path):
    res = gpr(core_path, '--help')
    assert res.returncode == 0, res.stderr
    for command in ('fk', 'ik', 'compensate', 'mobility', 'sweep', 'mechanism', 'accuracy', 'dexterity', 'verify'):
        assert command in res.stdout
    assert "unavailable: this command needs the optional package 'rosbags'" in res.stdout
