"""ROS 2 environment of the repository: the PyPI ROS Jazzy wheels in the venv plus the colcon ``install/``.

On a machine without a system ROS the ROS 2 Jazzy packages come from PyPI wheels installed into the virtual
environment, whose prefix (``sys.prefix``) is then an ament prefix itself (``share/ament_index``,
``share/<pkg>/cmake``, ``lib``). ``colcon build`` at the repository root adds ``install/gpr_interfaces`` and
``install/gpr_kinematics``. This module computes the environment that ``source install/setup.bash`` would
give (``AMENT_PREFIX_PATH``, ``CMAKE_PREFIX_PATH``, ``PYTHONPATH``, ``LD_LIBRARY_PATH``, ``PATH``), so that
tests, ``make demo`` and the benchmarks can start the nodes without a shell ``source``:

``python -m gpr_kinematics.ros.env exec -- CMD ARGS...``  run a command in that environment;
``python -m gpr_kinematics.ros.env print``                 print it as ``export`` lines (for ``eval``);
``python -m gpr_kinematics.ros.env fix-wheels``            repair the wheels' exported CMake files;
``python -m gpr_kinematics.ros.env base-paths``            the folders ``colcon build`` builds (see below);
``python -m gpr_kinematics.ros.env check``                 import rclpy and the custom interfaces.

``base-paths``: the repository's packages (the folders ``gpr_interfaces`` and ``gpr_kinematics``), plus
``fallback/<pkg>`` for each message package the nodes need that is installed nowhere in the ament prefixes
(:data:`FALLBACK_PACKAGES`: ``tf2_msgs`` and ``control_msgs``, which the PyPI wheels lack); a full ROS 2 install has
them, and then its own are used.

``fix-wheels``: the wheels were built under ``/opt/python/cpXY-cpXY`` (the interpreter's version) and their
exported CMake files name that interpreter's include directory and numpy include directory; building a custom
interface package against them fails until these paths point at the local interpreter's (idempotent rewrite).
This module imports no ROS package itself.
"""
from __future__ import annotations

import os
import sys
import sysconfig
from collections.abc import Mapping, Sequence
from pathlib import Path

#: Packages built by ``colcon build`` at the repository root, in dependency order.
COLCON_PACKAGES: tuple[str, ...] = ('gpr_interfaces', 'gpr_kinematics')
#: Message packages built from ``fallback/<name>`` only where none is installed, before the packages above.
FALLBACK_PACKAGES: tuple[str, ...] = ('tf2_msgs', 'control_msgs')

#: Where the wheels of this interpreter's version were built (named in their exported CMake files).
_BUILD_HOST_PYTHON = f'/opt/python/cp{sys.version_info.major}{sys.version_info.minor}' \
    f'-cp{sys.version_info.major}{sys.version_info.minor}'


def repo_root() -> Path:
    """Repository root (the folder holding ``colcon_defaults.yaml`` above the ``gpr_kinematics`` ROS package), for a
    source checkout."""
    return Path(__file__).resolve().parents[3]


def install_dir(root: Path | None = None) -> Path:
    """``install/`` of the colcon build; ``GPR_INSTALL_DIR`` overrides."""
    env = os.environ.get('GPR_INSTALL_DIR')
    if env:
        return Path(env).resolve()
    return (root or repo_root()) / 'install'


def built_packages(install: Path | None = None) -> tuple[str, ...]:
    """The packages of the colcon install tree in dependency order: the fallbacks that were built, then
    :data:`COLCON_PACKAGES`."""
    inst = install or install_dir()
    return tuple(p for p in FALLBACK_PACKAGES if (inst / p).is_dir()) + COLCON_PACKAGES


def installed_elsewhere(package: str, env: Mapping[str, str] | None = None, install: Path | None = None) -> bool:
    """Whether an ament prefix other than the repository's install tree (``AMENT_PREFIX_PATH``, the venv's
    wheel prefix) has ``package`` in its ament index."""
    env = os.environ if env is None else env
    inst = (install or install_dir()).resolve()
    prefixes = [p for p in env.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p] + [sys.prefix]
    for prefix in prefixes:
        path = Path(prefix).resolve()
        if path == inst or inst in path.parents:
            continue
        if (path / 'share' / 'ament_index' / 'resource_index' / 'packages' / package).is_file():
            return True
    return False


def colcon_base_paths(root: Path | None = None, env: Mapping[str, str] | None = None) -> list[str]:
    """Folders for ``colcon build --base-paths``: the repository's packages, and the fallback of every
    :data:`FALLBACK_PACKAGES` entry that no other ament prefix has."""
    root = root or repo_root()
    paths = list(COLCON_PACKAGES)
    paths += [f'fallback/{p}' for p in FALLBACK_PACKAGES
              if (root / 'fallback' / p).is_dir() and not installed_elsewhere(p, env)]
    return paths


def _python_dir() -> str:
    return f'python{sys.version_info.major}.{sys.version_info.minor}'


def _prepend(value: str | None, parts: Sequence[str]) -> str:
    existing = [p for p in (value or '').split(os.pathsep) if p]
    out: list[str] = []
    for p in list(parts) + existing:
        if p not in out:
            out.append(p)
    return os.pathsep.join(out)


def ros_environment(base: Mapping[str, str] | None = None, install: Path | None = None) -> dict[str, str]:
    """Return a copy of ``base`` (default ``os.environ``) with the ROS/colcon variables set.

    Prefix order as after ``source install/setup.bash``: the colcon packages first, then the venv's
    wheel prefix (the underlay). Raises ``FileNotFoundError`` naming the missing folder when the colcon
    install tree is absent (run ``make setup``).
    """
    env = dict(os.environ if base is None else base)
    inst = install or install_dir()
    missing = [name for name in COLCON_PACKAGES if not (inst / name).is_dir()]
    if missing:
        raise FileNotFoundError(f'colcon install tree incomplete: {", ".join(missing)} missing in {inst} '
                                '(run `make setup`)')
    venv = Path(sys.prefix)
    site = venv / 'lib' / _python_dir() / 'site-packages'
    packages = list(reversed(built_packages(inst)))
    prefixes = [str(inst / name) for name in packages] + [str(venv)]
    py_paths = [str(inst / name / 'lib' / _python_dir() / 'site-packages') for name in packages]
    lib_paths = [str(inst / name / 'lib') for name in packages] + [str(venv / 'lib')]
    lib_paths += sorted(str(p) for p in site.glob('ros_*.libs') if p.is_dir())
    env['AMENT_PREFIX_PATH'] = _prepend(env.get('AMENT_PREFIX_PATH'), prefixes)
    env['CMAKE_PREFIX_PATH'] = _prepend(env.get('CMAKE_PREFIX_PATH'), prefixes)
    env['PYTHONPATH'] = _prepend(env.get('PYTHONPATH'), py_paths)
    env['LD_LIBRARY_PATH'] = _prepend(env.get('LD_LIBRARY_PATH'), lib_paths)
    env['PATH'] = _prepend(env.get('PATH'), [str(venv / 'bin')])
    env.setdefault('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')
    return env


def find_executable(package: str, executable: str, env: Mapping[str, str] | None = None) -> Path:
    """Locate ``lib/<package>/<executable>`` the way ``ros2 run`` does.

    ``ros2 run`` asks the ament index for the package's prefix (the first prefix on ``AMENT_PREFIX_PATH``
    with ``share/ament_index/resource_index/packages/<package>``) and runs ``<prefix>/lib/<package>/<exe>``.
    """
    env = os.environ if env is None else env
    for prefix in env.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if prefix and (Path(prefix) / 'share' / 'ament_index' / 'resource_index' / 'packages' / package).is_file():
            exe = Path(prefix) / 'lib' / package / executable
            if exe.is_file() and os.access(exe, os.X_OK):
                return exe
            raise FileNotFoundError(f'package {package!r} found at {prefix} but it has no executable '
                                    f'{executable!r} in lib/{package}')
    raise FileNotFoundError(f'package {package!r} not found in the ament index (AMENT_PREFIX_PATH)')


def activate(install: Path | None = None) -> dict[str, str]:
    """Put the current process into the ROS environment of :func:`ros_environment`, without a re-exec.

    Sets the variables in ``os.environ`` (the ROS libraries read them at run time), prepends the install's
    Python folders to ``sys.path`` and preloads the colcon-built interface libraries
    (``install/<pkg>/lib/lib*.so``) with ``RTLD_GLOBAL``: the generated C extensions name them as
    ``DT_NEEDED`` entries, which the dynamic loader resolves against already loaded objects, since
    ``LD_LIBRARY_PATH`` is read only when a process starts. Idempotent; returns the environment.
    """
    import ctypes

    env = ros_environment(install=install)
    os.environ.update(env)
    for p in reversed(env['PYTHONPATH'].split(os.pathsep)):
        if p and p not in sys.path:
            sys.path.insert(0, p)
    inst = install or install_dir()
    pending = sorted(p for name in built_packages(inst) for p in (inst / name / 'lib').glob('lib*.so'))
    # Load in dependency order: retry what fails until no library loads any more.
    while pending:
        failed = []
        for lib in pending:
            try:
                ctypes.CDLL(str(lib), mode=ctypes.RTLD_GLOBAL)
            except OSError:
                failed.append(lib)
        if len(failed) == len(pending):
            ctypes.CDLL(str(failed[0]), mode=ctypes.RTLD_GLOBAL)  # raises, naming the missing dependency
        pending = failed
    return env


def _cmake_replacements() -> list[tuple[str, str]]:
    import numpy  # the venv's numpy, whose headers the generated C extensions compile against

    include = sysconfig.get_paths()['include']
    pyver = _python_dir()
    return [
        (f'{_BUILD_HOST_PYTHON}/lib/{pyver}/site-packages/numpy/_core/include', numpy.get_include()),
        (f'{_BUILD_HOST_PYTHON}/include/{pyver}', include),
    ]


def fix_wheels(prefix: Path | None = None) -> int:
    """Point the build host's interpreter paths in the wheels' ``*.cmake`` files at the local ones.

    Returns the number of files changed (0 on a second run: idempotent).
    """
    share = (prefix or Path(sys.prefix)) / 'share'
    reps = _cmake_replacements()
    changed = 0
    for path in share.glob('*/cmake/*.cmake'):
        text = path.read_text(encoding='utf-8', errors='surrogateescape')
        if _BUILD_HOST_PYTHON not in text:
            continue
        new = text
        for old, rep in reps:
            new = new.replace(old, rep)
        if new != text:
            path.write_text(new, encoding='utf-8', errors='surrogateescape')
            changed += 1
    return changed


def _check() -> int:
    import rclpy
    from control_msgs.action import FollowJointTrajectory
    from tf2_msgs.msg import TFMessage

    from gpr_interfaces import msg, srv
    from gpr_interfaces.action import RunProgram

    rclpy.init()
    try:
        node = rclpy.create_node('gpr_env_check')
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    names = [t.__name__ for t in (msg.PlatformState, msg.ProgramStation, msg.RobotState, srv.ForwardKinematics,
                                   srv.InverseKinematics, srv.Compensate, srv.AnalyzeMobility,
                                   srv.RobotForwardKinematics, srv.StationInverseKinematics, RunProgram)]
    def origin(t: type) -> Path:
        return Path(sys.modules[t.__module__].__file__ or '').parents[2]

    print(f'rclpy {Path(rclpy.__file__).parent}, gpr_interfaces ({", ".join(names)}), tf2_msgs '
          f'({TFMessage.__name__} from {origin(TFMessage)}) and control_msgs ({FollowJointTrajectory.__name__} from '
          f'{origin(FollowJointTrajectory)}) import and run')
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    usage = 'usage: python -m gpr_kinematics.ros.env {exec -- CMD...|print|fix-wheels|base-paths|check}'
    if not args:
        print(usage, file=sys.stderr)
        return 2
    cmd, rest = args[0], args[1:]
    if cmd == 'fix-wheels':
        print(f'fix-wheels: {fix_wheels()} CMake file(s) repointed at {sys.prefix}')
        return 0
    if cmd == 'base-paths':
        print(' '.join(colcon_base_paths()))
        return 0
    try:
        env = ros_environment()
    except FileNotFoundError as exc:
        print(f'ros_env: {exc}', file=sys.stderr)
        return 2
    if cmd == 'print':
        for key in ('AMENT_PREFIX_PATH', 'CMAKE_PREFIX_PATH', 'PYTHONPATH', 'LD_LIBRARY_PATH', 'PATH',
                    'RMW_IMPLEMENTATION'):
            print(f"export {key}='{env[key]}'")
        return 0
    if cmd == 'check':
        os.environ.update(env)
        # The library path must be in place before the ROS libraries load: re-run in the environment.
        os.execve(sys.executable, [sys.executable, '-c',
                                   'import sys; from gpr_kinematics.ros.env import _check; sys.exit(_check())'],
                  env)
    if cmd == 'exec':
        if rest and rest[0] == '--':
            rest = rest[1:]
        if not rest:
            print(usage, file=sys.stderr)
            return 2
        try:
            os.execvpe(rest[0], rest, env)
        except FileNotFoundError:
            print(f'ros_env: command not found: {rest[0]}', file=sys.stderr)
            return 127
    print(usage, file=sys.stderr)
    return 2


if __name__ == '__main__':
    sys.exit(main())
