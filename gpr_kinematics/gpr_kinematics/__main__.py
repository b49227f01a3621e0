"""``python -m gpr_kinematics``: the ``gpr`` command line (:func:`gpr_kinematics.cli.main.main`)."""
import sys

from .cli.main import main

sys.exit(main())
