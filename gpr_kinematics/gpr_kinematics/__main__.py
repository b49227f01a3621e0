"""``python -m gpr_kinematics``: the ``gpr`` command line (:func:`gpr_kinematics.cli.entry.main`)."""
import sys

from .cli.entry import main

sys.exit(main())
