"""ament_python package gpr_kinematics (also installable with pip)."""
from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'gpr_kinematics'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
        ('share/' + PACKAGE + '/config', glob('config/*.yaml')),
        # every folder of config/, each file as it is (cells/ was left out: the documented cell:= failed installed)
        *(('share/' + PACKAGE + '/' + folder, sorted(glob(folder + '/*.*')))
          for folder in sorted(path.rstrip('/') for path in glob('config/*/'))),
        ('share/' + PACKAGE + '/launch', glob('launch/*.launch.py') + glob('launch/*.launch.xml')),
        ('share/' + PACKAGE + '/rviz', glob('rviz/*.rviz')),
        ('share/' + PACKAGE + '/urdf', glob('urdf/*.urdf')),
    ],
    # The core and its CLI (fk, ik, compensate, mobility, sweep, mechanism, accuracy, workspace) need only these.
    install_requires=['setuptools', 'numpy', 'scipy', 'pyyaml'],
    # Optional parts (exact pins in requirements.txt / requirements-ros.txt / requirements-bench.txt):
    # bags: gpr verify and the recorder/replay nodes' files; plot: PNG figures (dexterity, workspace, verify
    # reports); ros: the nodes (ROS 2 Jazzy from the PyPI wheels; the interfaces are built with colcon);
    # bench: the peers of the benchmarks and numba for the compiled-code experiment (bench_compiled.py); safety:
    # collision distances of gpr program check (python-fcl).
    extras_require={
        'bags': ['rosbags', 'mcap', 'mcap-ros2-support'],
        'plot': ['matplotlib'],
        'ros': ['ros-jazzy-rclpy[fastrtps]', 'ros-jazzy-common-interfaces'],
        'cluster': ['dask', 'distributed'],
        'safety': ['python-fcl'],
        'bench': ['pin', 'codac', 'numba'],
    },
    zip_safe=True,
    maintainer='gpr_kinematics maintainers',
    maintainer_email='maintainers@gpr-kinematics.org',
    description='GPR tilting Z axis kinematics with virtual joints, as a ROS 2 node suite.',
    license='Apache-2.0',
    tests_require=['pytest'],
    python_requires='>=3.10',
    entry_points={
        'console_scripts': [
            'gpr = gpr_kinematics.cli.entry:main',
            'kinematics_node = gpr_kinematics.nodes.kinematics_node:main',
            'trajectory_node = gpr_kinematics.nodes.trajectory_node:main',
            'recorder_node = gpr_kinematics.nodes.recorder_node:main',
            'replay_node = gpr_kinematics.nodes.replay_node:main',
            'state_publisher_node = gpr_kinematics.nodes.state_publisher_node:main',
            'robot_simulator_node = gpr_kinematics.nodes.robot_simulator_node:main',
        ],
    },
)
