"""The ``gpr`` command line: one module per subcommand (or group of subcommands), dispatched by :mod:`.main`.

``gpr`` is :func:`gpr_kinematics.cli.main.main` (through :mod:`.entry`); each subcommand module has a
``register(subparsers)`` function and is imported only when its subcommand runs
(:data:`gpr_kinematics.cli.main.COMMANDS`).
"""
