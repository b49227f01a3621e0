"""package.xml (the stock ROS install's view of the package) declares every runtime dependency: each module the
package imports maps to a rosdep key listed as an exec_depend, and the executables, launch files, RViz
configuration and robot model are installed where ``ros2 run``/``ros2 launch`` look for them (setup.py)."""
from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Imported top-level module -> rosdep key (ROS packages are their own key).
ROSDEP = {
    'numpy': 'python3-numpy', 'scipy': 'python3-scipy', 'yaml': 'python3-yaml', 'matplotlib': 'python3-matplotlib',
    'mpl_toolkits': 'python3-matplotlib', 'rosbags': 'python3-rosbags-pip', 'mcap': 'mcap-ros2-support',
    'mcap_ros2': 'mcap-ros2-support',
    'backports': 'python3-rosbags-pip',  # backports.zstd, the zstd of rosbags, installed with it
}
#: Imported modules that have no rosdep key (rosdistro's rosdep/python.yaml, checked 2026-12-01): installed with pip
#: (requirements.txt, requirements-ros.txt, setup.py's extras, by their distribution's name), and named in a comment of
#: package.xml.
PIP_ONLY = {'lz4': 'lz4', 'dask': 'dask', 'distributed': 'distributed', 'fcl': 'python-fcl'}
#: The rosdep keys package.xml may use besides ROS packages: each checked to exist in rosdistro's rosdep files.
ROSDEP_KEYS = set(ROSDEP.values()) | {'python3-pytest', 'python3-hypothesis', 'python3-yourdfpy-pip'}
ROS_PACKAGES = {'rclpy', 'rcl_interfaces', 'builtin_interfaces', 'action_msgs', 'std_msgs', 'geometry_msgs',
                'sensor_msgs', 'visualization_msgs', 'tf2_msgs', 'trajectory_msgs', 'control_msgs', 'gpr_interfaces',
                'ament_index_python', 'launch', 'launch_ros', 'rosgraph_msgs'}


def imported_modules() -> dict[str, set[str]]:
    """Top-level modules imported anywhere in the package (lazy imports included) -> the files importing them."""
    out: dict[str, set[str]] = {}
    for path in (ROOT / 'gpr_kinematics' / 'gpr_kinematics').rglob('*.py'):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                top = name.split('.')[0]
                if top not in sys.stdlib_module_names and top != 'gpr_kinematics':
                    out.setdefault(top, set()).add(str(path.relative_to(ROOT)))
    return out


def exec_depends() -> set[str]:
    manifest = (ROOT / 'gpr_kinematics' / 'package.xml').read_text()
    return set(re.findall(r'<exec_depend>([\w-]+)</exec_depend>', manifest))


def test_every_import_is_declared():
    declared = exec_depends()
    missing = {m: files for m, files in imported_modules().items()
               if m not in PIP_ONLY and (m if m in ROS_PACKAGES else ROSDEP.get(m)) not in declared}
    assert not missing, f'imports without an exec_depend in package.xml (add the rosdep key): {missing}'


def test_dependencies_are_rosdep_keys_or_named_pip_packages():
    manifest = (ROOT / 'gpr_kinematics' / 'package.xml').read_text()
    keys = set(re.findall(r'<(?:exec|test|build)_depend>([\w-]+)</', manifest))
    unknown = keys - ROSDEP_KEYS - ROS_PACKAGES - {'launch_xml', 'rviz2'}
    assert not unknown, f'not rosdep keys: {unknown}'
    comment = ' '.join(re.findall(r'<!--(.*?)-->', manifest, re.S))
    requirements = ''.join((ROOT / f).read_text().lower() for f in ('requirements.txt', 'requirements-ros.txt'))
    for name, dist in PIP_ONLY.items():
        assert name in comment and f'\n{dist}==' in '\n' + requirements, name


def test_every_config_file_is_installed_in_its_folder(monkeypatch):
    """setup.py's data_files hold every file of config/ under share/gpr_kinematics/config/ (cells/ was left out:
    the documented ``cell:=`` of an installed package failed; the colcon test checks the installed tree)."""
    import runpy
    from unittest import mock

    package = ROOT / 'gpr_kinematics'
    monkeypatch.chdir(package)   # setup.py globs relative to its folder, as colcon and pip run it
    with mock.patch('setuptools.setup') as setup:
        runpy.run_path(str(package / 'setup.py'))
    installed = {str(Path(target) / Path(f).name) for target, files in setup.call_args.kwargs['data_files']
                 for f in files}
    for f in (package / 'config').rglob('*.*'):
        assert str(Path('share/gpr_kinematics') / f.relative_to(package)) in installed, f


def test_launch_rviz_and_robot_model_installed():
    text = (ROOT / 'gpr_kinematics' / 'setup.py').read_text()
    for folder, pattern in (('launch', "glob('launch/*.launch.py')"), ('launch', "glob('launch/*.launch.xml')"),
                            ('rviz', "glob('rviz/*.rviz')"), ('urdf', "glob('urdf/*.urdf')"),
                            ('config', "glob('config/*.yaml')")):
        assert f"'share/' + PACKAGE + '/{folder}', " in text and pattern in text, (folder, pattern)
    assert {'launch', 'launch_ros', 'launch_xml', 'rviz2'} <= exec_depends()
