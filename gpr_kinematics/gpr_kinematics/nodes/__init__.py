"""ROS 2 nodes of gpr_kinematics: thin adapters between ``gpr_interfaces`` messages and the numpy core.

Executables (``ros2 run gpr_kinematics ...``): ``kinematics_node`` (services) and ``trajectory_node``
(streams of compensated platform poses). Only this subpackage imports ROS.
"""
