"""The ROS side of the package that needs no ROS import: the environment of a checkout (:mod:`.env`), node
processes (:mod:`.process`), the nodes' parameters (:mod:`.specs`), what the trajectory node streams
(:mod:`.streams`) and the offline-programming loop of ``make demo`` (:mod:`.offline_loop`). The ROS nodes
themselves, which import rclpy, are in :mod:`gpr_kinematics.nodes`.
"""
