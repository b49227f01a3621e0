"""gpr_kinematics: kinematics of the GPR tilting Z axis with virtual joints, as a ROS 2 node suite.

The core (this package without ``nodes``) is pure numpy/scipy: :mod:`.config`, :mod:`.geometry`,
:mod:`.virtual_joints`, :mod:`.kinematics`, :mod:`.compensation`, :mod:`.mobility`, :mod:`.sweep`.
SI units (metres, radians) everywhere.
"""

__version__ = '0.1.0'
