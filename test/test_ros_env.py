"""gpr_kinematics.ros.env: the wheel CMake repair, the environment that replaces `source install/setup.bash`."""
from __future__ import annotations

import os
import re
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


@pytest.mark.parametrize('package', ros_env.FALLBACK_PACKAGES)
def test_fallback_only_where_none_is_installed(tmp_path, package):
    """colcon builds fallback/<package> (tf2_msgs, control_msgs) only when no other ament prefix has it (a full ROS
    install has both)."""
    assert set(ros_env.FALLBACK_PACKAGES) == {'tf2_msgs', 'control_msgs'}
    root = ros_env.repo_root()
    bare = {'AMENT_PREFIX_PATH': str(tmp_path / 'empty')}
    assert ros_env.installed_elsewhere(package, bare) is False       # the PyPI wheels have none
    assert ros_env.colcon_base_paths(root, bare) == ['gpr_interfaces', 'gpr_kinematics', 'fallback/tf2_msgs',
                                                     'fallback/control_msgs']
    ros = tmp_path / 'opt_ros'
    index = ros / 'share' / 'ament_index' / 'resource_index' / 'packages'
    index.mkdir(parents=True)
    (index / package).write_text('')
    full = {'AMENT_PREFIX_PATH': str(ros)}
    assert ros_env.installed_elsewhere(package, full) is True
    assert f'fallback/{package}' not in ros_env.colcon_base_paths(root, full)
    assert len(ros_env.colcon_base_paths(root, full)) == 3
    # The repository's own install tree does not count as an installed package.
    own = {'AMENT_PREFIX_PATH': str(ros_env.install_dir() / package)}
    assert ros_env.installed_elsewhere(package, own) is False


#: The standard definitions the fallback control_msgs copies (ros-controls/control_msgs, branch jazzy, 5.8.0): the
#: fields, in order, of each part (comments and constants left out). The type hash derives from exactly these.
CONTROL_MSGS_FIELDS = {
    'msg/JointTolerance.msg': ['string name', 'float64 position', 'float64 velocity', 'float64 acceleration'],
    'msg/JointComponentTolerance.msg': ['string joint_name', 'uint16 component', 'float64 position',
                                        'float64 velocity', 'float64 acceleration'],
    'action/FollowJointTrajectory.action': [
        'trajectory_msgs/JointTrajectory trajectory', 'trajectory_msgs/MultiDOFJointTrajectory multi_dof_trajectory',
        'JointTolerance[] path_tolerance', 'JointComponentTolerance[] component_path_tolerance',
        'JointTolerance[] goal_tolerance', 'JointComponentTolerance[] component_goal_tolerance',
        'builtin_interfaces/Duration goal_time_tolerance', '---', 'int32 error_code', 'string error_string', '---',
        'std_msgs/Header header', 'string[] joint_names', 'trajectory_msgs/JointTrajectoryPoint desired',
        'trajectory_msgs/JointTrajectoryPoint actual', 'trajectory_msgs/JointTrajectoryPoint error',
        'string[] multi_dof_joint_names', 'trajectory_msgs/MultiDOFJointTrajectoryPoint multi_dof_desired',
        'trajectory_msgs/MultiDOFJointTrajectoryPoint multi_dof_actual',
        'trajectory_msgs/MultiDOFJointTrajectoryPoint multi_dof_error'],
}


def test_fallback_control_msgs_has_the_standard_fields():
    folder = ros_env.repo_root() / 'fallback' / 'control_msgs'
    for name, fields in CONTROL_MSGS_FIELDS.items():
        lines = [line.split('#')[0].strip() for line in (folder / name).read_text().splitlines()]
        assert [line for line in lines if line and '=' not in line] == fields, name
    text = (folder / 'action' / 'FollowJointTrajectory.action').read_text()
    codes = dict(re.findall(r'^int32 (\w+) = (-?\d+)$', text, re.M))
    assert codes == {'SUCCESSFUL': '0', 'INVALID_GOAL': '-1', 'INVALID_JOINTS': '-2', 'OLD_HEADER_TIMESTAMP': '-3',
                     'PATH_TOLERANCE_VIOLATED': '-4', 'GOAL_TOLERANCE_VIOLATED': '-5'}
