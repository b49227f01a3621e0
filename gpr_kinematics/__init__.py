"""gpr_kinematics: kinematics of the GPR tilting Z axis with virtual joints, as a ROS 2 node suite.

The core (this package without ``nodes`` and ``bags``) needs only numpy, scipy and PyYAML: :mod:`.config`,
:mod:`.machine`, :mod:`.geometry`, :mod:`.virtual_joints`, :mod:`.compliance`, :mod:`.kinematics` (with
:mod:`.forward`, :mod:`.inverse`, :mod:`.naive`, :mod:`.platform_pose`), :mod:`.compensation`, :mod:`.mobility`,
:mod:`.sweep`, :mod:`.mechanisms`. SI units (metres, radians) everywhere; the papers are listed in
``docs/references.md``.
"""

__version__ = '0.1.0'
