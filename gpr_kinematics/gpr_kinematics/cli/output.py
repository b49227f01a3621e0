"""What the ``gpr`` subcommands print and write: ``--json`` is the result dataclass itself (:func:`jsonable`), one
object; an output file is never one of the command's inputs (:func:`distinct_outputs`).

Each subcommand's ``--json`` is one result dataclass of the layer that computed it (``ForwardResult``,
``RobotForwardRecord``, ``PoseAnalysis``, ``WorkspaceSummary``, ``VerifyRecord``, ...): its fields are the keys.
:func:`emit_json` adds only what the command itself knows and the result cannot: the files it read or wrote.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import re
import sys
from typing import TypeAlias

import numpy as np

from ..bags.results import json_number
from ..errors import InputError

#: JSON data: what :func:`jsonable` returns and :func:`json.dump` writes.
JsonValue: TypeAlias = 'None | bool | int | float | str | list[JsonValue] | dict[str, JsonValue]'
JsonObject: TypeAlias = 'dict[str, JsonValue]'
#: The options (argparse ``dest``) that name a file or folder a subcommand writes.
OUTPUT_OPTIONS = ('output', 'csv', 'boxes', 'plot', 'waypoints', 'samples', 'report', 'trajectory')
#: A number's text that reads zero with a minus sign: ``-0`` (``-0.0``), ``-0.000000`` (``-2e-17``).
_NEGATIVE_ZERO = re.compile(r' *-0*\.?0*(?:e[-+]0+)?')


def number_text(value: float, spec: str) -> str:
    """``format(value, spec)``, zero without a minus sign (``tilt_x = -0`` read as a tilt).

    >>> number_text(-0.0, '.9g'), number_text(-2e-17, '8.3f'), number_text(-0.5, '.9g')
    ('0', '   0.000', '-0.5')
    """
    text = format(value, spec)
    return format(0.0, spec) if _NEGATIVE_ZERO.fullmatch(text) else text


def description(doc: str | None) -> str:
    """A module docstring's first paragraph as a ``--help`` description: its reST literals (````gpr````) and roles
    (``:func:`x```) printed as plain text."""
    first = (doc or '').split('\n\n')[0]
    return re.sub(r'``([^`]*)``', r'\1', re.sub(r':[a-z]+:`~?([^`]*)`', r'\1', first))


def jsonable(obj: object) -> JsonValue:
    """``obj`` as JSON data: a dataclass becomes the mapping of its fields (recursively; a field whose metadata
    says ``json: inline``, a mapping, gives its keys instead of a key of its own), numpy arrays and scalars become
    lists and numbers, tuples become lists, and a number that is not finite becomes the text ``"inf"``, ``"-inf"``
    or ``"nan"`` (:func:`~gpr_kinematics.bags.results.json_number`, as ``gpr verify``'s; JSON has no such numbers: an
    infinite slip ratio, the wafer lifted off its blade, ended the output in a traceback after half an object). This
    is the one schema of ``--json``.

    Raises:
        TypeError: a value that has no JSON form (``json.dump`` refused it the same way), or a key twice.
    """
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out: JsonObject = {}
        for f in dataclasses.fields(obj):
            value = jsonable(getattr(obj, f.name))
            if f.metadata.get('json') == 'inline' and isinstance(value, dict):
                _merge(out, value, type(obj).__name__)
            else:
                _merge(out, {f.name: value}, type(obj).__name__)
        return out
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return jsonable(obj.item())
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, float):
        return json_number(obj)
    if obj is None or isinstance(obj, (bool, int, float, str)):
        return obj
    raise TypeError(f'{type(obj).__name__} has no JSON form; allowed: dataclasses, numbers, strings, lists, '
                    'mappings and numpy arrays')


def _merge(out: JsonObject, more: JsonObject, what: str) -> None:
    twice = sorted(set(out) & set(more))
    if twice:
        raise TypeError(f'{what} gives the keys {twice} twice')
    out.update(more)


def json_object(obj: object) -> JsonObject:
    """:func:`jsonable` of a dataclass (or a mapping): a JSON object."""
    data = jsonable(obj)
    if not isinstance(data, dict):
        raise TypeError(f'{type(obj).__name__} is not a JSON object; allowed: a dataclass or a mapping')
    return data


def emit_json(result: object, **context: JsonValue) -> None:
    """Print the result dataclass ``result`` (:func:`jsonable`) as one JSON object on stdout, then the ``context``
    keys: what the command itself knows and the result cannot (the files it read or wrote), never a result's
    field again."""
    data = json_object(result)
    _merge(data, context, type(result).__name__)
    sys.stdout.write(json.dumps(data, allow_nan=False) + '\n')   # whole, or nothing if it cannot be written


def _given(value: object) -> list[str]:
    values = value if isinstance(value, list) else [value]
    return [v for v in values if isinstance(v, str) and v]


def _existing(value: object) -> list[str]:
    return [v for v in _given(value) if os.path.exists(v)]


def typed_name(parser: argparse.ArgumentParser | None, dest: str) -> str:
    """How the user names the argument ``dest`` of ``parser``: its option (``--config``), else its metavar
    (``MEASUREMENTS``); ``dest`` in capitals without a parser."""
    for action in () if parser is None else parser._actions:
        if action.dest == dest:
            if action.option_strings:
                return max(action.option_strings, key=len)
            return action.metavar if isinstance(action.metavar, str) else dest.upper()
    return dest.upper()


def distinct_outputs(args: argparse.Namespace, parser: argparse.ArgumentParser | None = None) -> None:
    """Refuse, before any work, an output (:data:`OUTPUT_OPTIONS`) that names an existing file or folder the command
    also takes as an input, or another output (``gpr calibrate M.csv --output M.csv`` overwrote the measurements
    with the calibrated geometry), each named as the command's ``parser`` names it (``--config``, not ``CONFIG``).
    Files the command reads without naming them (a robot's geometry file) are refused when written
    (:func:`gpr_kinematics.inputs.files.check_output`)."""
    values = vars(args)
    named = [(k, v) for k in OUTPUT_OPTIONS for v in _given(values.get(k))]
    for i, (key, out) in enumerate(named):  # two outputs of one path, existing or not: one table would be lost
        for other, path in named[i + 1:]:
            if os.path.normcase(os.path.realpath(out)) == os.path.normcase(os.path.realpath(path)):
                raise InputError(f'--{key} {out!r} and --{other} {path!r} are the same file; allowed: a file of its '
                                 'own for each output')
    outputs = [(k, v) for k in OUTPUT_OPTIONS for v in _existing(values.get(k))]
    others = [(k, v) for k, value in values.items() if k not in OUTPUT_OPTIONS for v in _existing(value)]
    for i, (key, out) in enumerate(outputs):
        for other, path in others + outputs[i + 1:]:
            try:
                same = os.path.samefile(out, path)
            except OSError:
                continue
            if same:
                what = 'an input of this command' if other not in OUTPUT_OPTIONS else 'another output'
                raise InputError(f'--{key} {out!r} is the same file as {typed_name(parser, other)} {path!r} ({what}); '
                                 'allowed: an output that is none of the files the command reads or writes')
