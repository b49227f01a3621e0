"""The whole robot on the GPR, for offline programming: description, kinematics, stations, teach, programs.

Pure numpy (no ROS import), vectorised over batches; results are frozen dataclasses (docs/robot.md):

* :mod:`.description`: :func:`load_robot` reads and validates a robot description (``config/robots/``);
* :mod:`.planar_arm`: a serial planar arm's forward and closed-form inverse kinematics, branches, redundancy;
* :mod:`.forward`: :func:`robot_forward`, rods + arm joints -> platform, blade and wafer in the world, exact and
  naive;
* :mod:`.stations`: :class:`Stations`, wafer poses in the world;
* :mod:`.inverse`: :func:`solve_stations`, stations -> rods + arm joints, with the naive model's wafer error;
* :mod:`.teach`: :func:`teach` (joints -> stations) and :func:`reteach` (naive joints -> corrected joints);
* :mod:`.program`, :mod:`.station_files`, :mod:`.timing`, :mod:`.export`: offline programs, station import,
  time parameterisation within the limits, joint tables for a controller.
"""
from .description import RobotDescription, load_robot
from .forward import RobotForward, robot_forward
from .inverse import StationSolution, solve_stations
from .stations import Stations, stations_from_poses
from .teach import Retaught, Taught, reteach, teach

__all__ = ['RobotDescription', 'RobotForward', 'Retaught', 'StationSolution', 'Stations', 'Taught', 'load_robot',
           'reteach', 'robot_forward', 'solve_stations', 'stations_from_poses', 'teach']
