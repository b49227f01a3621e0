"""gpr_kinematics.ros.env: the wheel CMake repair, the environment that replaces `source install/setup.bash`."""
from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import numpy
import pytest
from gpr_kinematics.ros import env as ros_env

#: The wheels of this interpreter were built under /opt/python/<CP>-<CP> (e.g. cp311-cp311).
CP = f'cp{sys.version_info.major}{sys.version_info.minor}'


def test_fix_wheels_repoints_build_host_paths_idempotently(tmp_path):
    cmake = tmp_path / 'share' / 'std_msgs' / 'cmake'
    cmake.mkdir(parents=True)
    f = cmake / 'export_std_msgs__rosidl_generator_pyExport.cmake'
    host, py = f'/opt/python/{CP}-{CP}', f'python{sys.version_info.major}.{sys.version_info.minor}'
    f.write_text(f'INTERFACE_INCLUDE_DIRECTORIES "{host}/include/{py};'
                 f'{host}/lib/{py}/site-packages/numpy/_core/include"\n')
    untouched = cmake / 'other.cmake'
    untouched.write_text('set(X 1)\n')
    assert ros_env.fix_wheels(tmp_path) == 1
    text = f.read_text()
    assert '/opt/python' not in text
    assert sysconfig.get_paths()['include'] in text and numpy.get_include() in text
    assert ros_env.fix_wheels(tmp_path) == 0
    assert untouched.read_text() == 'set(X 1)\n'


def test_installed_wheels_are_repaired():
    """make setup ran fix-wheels on the venv: no exported CMake file names the build host any more."""
    share = Path(sys.prefix) / 'share'
    files = list(share.glob('*/cmake/*.cmake'))
    assert len(files) > 50
    assert not [p for p in files if f'/opt/python/{CP}-{CP}' in p.read_text(errors='replace')]


def test_environment_like_setup_bash(tmp_path):
    inst = ros_env.install_dir()
    env = ros_env.ros_environment(base={'PATH': '/usr/bin', 'LD_LIBRARY_PATH': '/opt/x'})
    prefixes = env['AMENT_PREFIX_PATH'].split(os.pathsep)
    built = ros_env.built_packages()
    assert built[-2:] == ('gpr_interfaces', 'gpr_kinematics')
    assert prefixes[:len(built) + 1] == [str(inst / p) for p in reversed(built)] + [sys.prefix]
    assert env['LD_LIBRARY_PATH'].split(os.pathsep)[0] == str(inst / 'gpr_kinematics' / 'lib')
    assert env['LD_LIBRARY_PATH'].endswith('/opt/x')
    assert str(inst / 'gpr_interfaces' / 'lib') in env['LD_LIBRARY_PATH']
    assert env['PATH'].startswith(str(Path(sys.prefix) / 'bin'))
    with pytest.raises(FileNotFoundError, match='make setup'):
        ros_env.ros_environment(install=tmp_path)


def test_exec_runs_a_command_with_the_interfaces_importable():
    code = 'from gpr_interfaces.msg import PlatformState; print(PlatformState().header.frame_id == "")'
    out = subprocess.run([sys.executable, '-m', 'gpr_kinematics.ros.env', 'exec', '--', sys.executable, '-c', code],
                         capture_output=True, text=True, timeout=60, env={k: v for k, v in os.environ.items()
                                                                          if k != 'LD_LIBRARY_PATH'})
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == 'True'


def test_cli_usage_errors():
    for args in ([], ['frobnicate'], ['exec', '--']):
        out = subprocess.run([sys.executable, '-m', 'gpr_kinematics.ros.env', *args], capture_output=True,
                             text=True, timeout=60)
        assert out.returncode == 2 and 'usage' in out.stderr


def test_fallback_tf2_msgs_only_where_none_is_installed(tmp_path):
    """colcon builds fallback/tf2_msgs only when no other ament prefix has tf2_msgs (a full ROS install has)."""
    root = ros_env.repo_root()
    bare = {'AMENT_PREFIX_PATH': str(tmp_path / 'empty')}
    assert ros_env.installed_elsewhere('tf2_msgs', bare) is False       # the PyPI wheels have none
    assert ros_env.colcon_base_paths(root, bare) == ['gpr_interfaces', 'gpr_kinematics', 'fallback/tf2_msgs']
    ros = tmp_path / 'opt_ros'
    index = ros / 'share' / 'ament_index' / 'resource_index' / 'packages'
    index.mkdir(parents=True)
    (index / 'tf2_msgs').write_text('')
    full = {'AMENT_PREFIX_PATH': str(ros)}
    assert ros_env.installed_elsewhere('tf2_msgs', full) is True
    assert ros_env.colcon_base_paths(root, full) == ['gpr_interfaces', 'gpr_kinematics']
    # The repository's own install tree does not count as an installed tf2_msgs.
    own = {'AMENT_PREFIX_PATH': str(ros_env.install_dir() / 'tf2_msgs')}
    assert ros_env.installed_elsewhere('tf2_msgs', own) is False
