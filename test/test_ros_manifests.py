"""The manifests are valid: every package.xml is well-formed XML of format 3 (REP 149's schema) that catkin_pkg (used
by colcon-ros, rosdep, bloom and ``ros2 pkg``) accepts, and a clone under a workspace's ``src/`` builds all its
packages with a plain ``colcon build``."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from catkin_pkg.package import InvalidPackage, parse_package, parse_package_string
from gpr_kinematics.ros.env import install_dir
from lxml import etree

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = Path(__file__).resolve().parent / 'data' / 'rep149' / 'package_format3.xsd'
#: Every manifest of the repository and the build type colcon must see.
MANIFESTS = {'gpr_kinematics/package.xml': 'ament_python', 'gpr_interfaces/package.xml': 'ament_cmake',
             'fallback/tf2_msgs/package.xml': 'ament_cmake', 'fallback/control_msgs/package.xml': 'ament_cmake'}


def tracked_files() -> list[str]:
    out = subprocess.run(['git', 'ls-files', '-co', '--exclude-standard'], cwd=ROOT, capture_output=True, text=True,
                         timeout=60, check=True).stdout.split()
    return [f for f in out if (ROOT / f).is_file()]


def test_every_manifest_is_listed():
    assert sorted(f for f in tracked_files() if Path(f).name == 'package.xml') == sorted(MANIFESTS)


@pytest.mark.parametrize('manifest', sorted(MANIFESTS))
def test_manifest_parses_with_catkin_pkg_and_the_format_3_schema(manifest):
    path = ROOT / manifest
    package = parse_package(str(path))
    assert package.package_format == 3 and package.name == path.parent.name
    assert package.get_build_type() == MANIFESTS[manifest]
    schema = etree.XMLSchema(etree.parse(str(SCHEMA)))
    assert schema.validate(etree.parse(str(path))), schema.error_log


def test_the_checks_refuse_a_comment_with_a_double_hyphen():
    text = (ROOT / 'gpr_kinematics' / 'package.xml').read_text()
    broken = text.replace('<export>', '<!-- gpr workspace --scheduler --><export>')
    with pytest.raises(InvalidPackage):
        parse_package_string(broken)
    with pytest.raises(etree.XMLSyntaxError):
        etree.fromstring(broken.encode())


def _colcon() -> str:
    exe = Path(sys.executable).with_name('colcon')
    if not exe.exists():
        pytest.skip('colcon is not installed in this environment (make setup installs it)')
    return str(exe)


def _workspace(tmp_path: Path) -> Path:
    """A workspace ``ws/`` with this repository's files (committed or not, as git lists them) under ``src/``."""
    ws = tmp_path / 'ws'
    clone = ws / 'src' / 'gpr_repo'
    for name in tracked_files():
        dest = clone / name
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, dest)
    return ws


def _env() -> dict[str, str]:
    venv = Path(sys.prefix)
    return os.environ | {'PATH': f'{venv / "bin"}{os.pathsep}{os.environ.get("PATH", "")}',
                         'AMENT_PREFIX_PATH': str(venv), 'CMAKE_PREFIX_PATH': str(venv)}


def test_colcon_finds_both_packages_in_a_standard_workspace(tmp_path):
    ws = _workspace(tmp_path)
    res = subprocess.run([_colcon(), 'list'], cwd=ws, capture_output=True, text=True, timeout=120, env=_env())
    assert res.returncode == 0, res.stderr
    found = {line.split('\t')[0]: line.split('\t')[2] for line in res.stdout.splitlines()}
    # the fallback message packages are built only where none is installed (the Makefile adds them)
    assert found == {'gpr_interfaces': '(ros.ament_cmake)', 'gpr_kinematics': '(ros.ament_python)'}, res.stdout


def test_colcon_builds_and_installs_the_python_package_in_a_standard_workspace(tmp_path):
    """A plain ``colcon build`` in ``ws/`` (no ``colcon_defaults.yaml`` there: a copy install, not the setup's symlinks)
    over the setup's install as its underlay installs gpr_kinematics whole. gpr_interfaces is not built a second time
    here: ``make setup`` builds it from the same CMakeLists with the same arguments (two CPU-minutes of C and C++ each
    time), and the next test checks what it installed."""
    underlay = install_dir()
    if not (underlay / 'gpr_interfaces').is_dir():
        pytest.skip('no colcon build of gpr_interfaces to overlay (make setup builds it)')
    ws = _workspace(tmp_path)
    python = sys.executable
    env = _env() | {'COLCON_PREFIX_PATH': str(underlay)}       # the setup's install sourced as the underlay
    res = subprocess.run([_colcon(), 'build', '--packages-select', 'gpr_kinematics', '--cmake-args',
                          f'-DPython3_EXECUTABLE={python}', f'-DPYTHON_EXECUTABLE={python}', '-DBUILD_TESTING=OFF'],
                         cwd=ws, capture_output=True, text=True, timeout=900, env=env)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    assert 'Summary: 1 package finished' in res.stdout, res.stdout[-2000:]
    share = ws / 'install' / 'gpr_kinematics' / 'share' / 'gpr_kinematics'
    assert parse_package(str(share / 'package.xml')).name == 'gpr_kinematics'   # what `ros2 pkg xml` prints
    assert (ws / 'install' / 'gpr_kinematics' / 'lib' / 'gpr_kinematics' / 'kinematics_node').is_file()
    assert not (share / 'package.xml').is_symlink()
    # every file of config/, in its folder: cells/ was left out, and the documented cell:= of an installed package
    # and the installed cell program failed
    config = ROOT / 'gpr_kinematics' / 'config'
    for f in config.rglob('*.*'):
        assert (share / 'config' / f.relative_to(config)).is_file(), f"{f.relative_to(config)} is not installed"


def test_make_setup_installed_every_interface_of_gpr_interfaces():
    """The setup's build of gpr_interfaces (the CMakeLists a standard workspace builds) installed each interface file
    and its Python module."""
    prefix = install_dir() / 'gpr_interfaces'
    if not prefix.is_dir():
        pytest.skip('no colcon build of gpr_interfaces (make setup builds it)')
    share = prefix / 'share' / 'gpr_interfaces'
    sources = sorted(f.relative_to(ROOT / 'gpr_interfaces') for f in (ROOT / 'gpr_interfaces').glob('*/*.*')
                     if f.suffix in ('.msg', '.srv', '.action'))
    assert len(sources) == 10, sources
    for f in sources:
        assert (share / f).is_file(), f'{f} is not installed'
    modules = {p.name for p in prefix.glob('lib/python3*/site-packages/gpr_interfaces/*') if p.is_dir()}
    assert {'msg', 'srv', 'action'} <= modules, modules
    assert (prefix / 'lib' / 'libgpr_interfaces__rosidl_typesupport_c.so').is_file()
    assert parse_package(str(share / 'package.xml')).name == 'gpr_interfaces'


def test_the_interfaces_name_every_virtual_joint_model():
    """ForwardKinematics, InverseKinematics, Compensate, AnalyzeMobility and PlatformState said their model was one of
    radial, polar, offset; the services take compliant too (config.MODELS): every comment on a model names each."""
    from gpr_kinematics.core.config import MODELS

    files = sorted((ROOT / 'gpr_interfaces').glob('*/*.*'))
    said = [(f.name, line) for f in files if f.suffix in ('.msg', '.srv', '.action')
            for line in f.read_text().splitlines() if line.startswith('#') and 'Virtual-joint model' in line]
    assert len(said) >= 5, said
    for name, line in said:
        assert all(m in line for m in MODELS), (name, line)
