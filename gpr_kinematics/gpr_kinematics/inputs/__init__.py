"""What the package reads and writes: bounded files and YAML, the checks of their keys and values, units of CSV
columns, and the package's own data files. Below every other part of the package (it imports only
:mod:`gpr_kinematics.errors`).
"""
