"""The params files of a node's command line, read with the package's bounded YAML reader before rcl reads them
(no ROS here: :func:`check_params_files` is called by :func:`~gpr_kinematics.nodes.runtime.run` before ``rclpy.init``).

rcl's own parser (``rcl_yaml_param_parser``) takes time growing with the square of a list's values and of the node
sections (a list of 80,000 values, a 320 kB file, took 5 to 20 s, a million 12 minutes), and a node ignores SIGTERM
while it parses; it also keeps the last of a key given twice without a word. So every ``--params-file FILE`` of a
``--ros-args`` section is first read by :func:`~gpr_kinematics.inputs.safe_yaml.load_documents` and refused, naming
the file and the limit, beyond :data:`MAX_PARAMS_BYTES` bytes, :data:`MAX_PARAMS_VALUES` YAML values (keys, values,
lists and mappings, over all its documents), :data:`~gpr_kinematics.inputs.safe_yaml.MAX_DEPTH` levels, with an alias
(rcl refuses them too) or a key twice in one mapping (naming both lines). A file within them takes rcl less than
0.2 s; the shipped ``gpr_params.yaml`` has about 200 values. Its ``ros__parameters`` form is left to rcl.
"""
from __future__ import annotations

from collections.abc import Iterator, Sequence

from ..errors import PATH_LENGTH, ConfigError, brief
from ..inputs.files import read_text
from ..inputs.safe_yaml import load_documents

#: Largest params file read [bytes] (1 MiB; the shipped one is about 10 kB).
MAX_PARAMS_BYTES = 1 << 20
#: Most YAML values in one params file: rcl reads 20,000 in 0.1 s (a list), 0.2 s (node sections); 80,000 took 5 s.
MAX_PARAMS_VALUES = 20_000
#: The ``--ros-args`` flags that take a value (rcl's ``arguments.c``): their value is never read as a flag.
_WITH_VALUE = frozenset({'-r', '--remap', '-p', '--param', '--params-file', '-e', '--enclave', '--log-level',
                         '--log-file-name', '--log-config-file'})


def params_files(args: Sequence[str]) -> Iterator[str]:
    """The ``FILE`` of each ``--params-file FILE`` within a ``--ros-args`` section of ``args`` (a section ends at
    ``--``), in order; a flag without its value is left to rcl.

    >>> list(params_files(['n', '--params-file', 'a', '--ros-args', '-p', 'x:=1', '--params-file', 'b', '--', 'c']))
    ['b']
    """
    inside = False
    items = iter(args)
    for arg in items:
        if arg == '--ros-args':
            inside = True
        elif arg == '--':
            inside = False
        elif inside and arg in _WITH_VALUE:
            value = next(items, None)
            if arg == '--params-file' and value is not None:
                yield value


def check_params_files(args: Sequence[str]) -> None:
    """Read every params file of ``args`` (:func:`params_files`) under the bounds of the module docstring.

    Raises:
        ConfigError: a file missing, unreadable, not a regular file, larger than :data:`MAX_PARAMS_BYTES`, not UTF-8,
            not YAML, beyond the bounds, or with a key twice, naming the file (cut by :func:`brief` to
            :data:`~gpr_kinematics.errors.PATH_LENGTH`) and the limit.
    """
    for path in params_files(args):
        name = brief(path, PATH_LENGTH)
        try:
            text = read_text(path, 'params', MAX_PARAMS_BYTES)
        except ConfigError as exc:
            raise ConfigError(_renamed(str(exc), path, name)) from None
        load_documents(text, f'params file {name}', MAX_PARAMS_VALUES, MAX_PARAMS_BYTES,
                       "rcl's parser takes seconds beyond, and a node cannot be stopped while it parses")


def _renamed(message: str, path: str, name: str) -> str:
    """``message`` of :func:`read_text` with the path it quotes whole cut to ``name``."""
    return message.replace(repr(path), name)
