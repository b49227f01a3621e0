"""Safe programs: the process cell, the certified clearance of a program against it and between the robot's own
bodies, wafer slip on the blade, and the report of ``gpr program check`` (docs/cell.md)."""
