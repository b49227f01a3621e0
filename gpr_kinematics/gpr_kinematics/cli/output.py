"""What the ``gpr`` subcommands print: ``--json`` is the result dataclass itself (:func:`jsonable`), one object.

Each subcommand's ``--json`` is one result dataclass of the layer that computed it (``ForwardResult``,
``RobotForwardRecord``, ``PoseAnalysis``, ``WorkspaceSummary``, ``VerifyRecord``, ...): its fields are the keys.
:func:`emit_json` adds only what the command itself knows and the result cannot: the files it read or wrote.
"""
from __future__ import annotations

import dataclasses
import json
import sys
from typing import TypeAlias

import numpy as np

#: JSON data: what :func:`jsonable` returns and :func:`json.dump` writes.
JsonValue: TypeAlias = 'None | bool | int | float | str | list[JsonValue] | dict[str, JsonValue]'
JsonObject: TypeAlias = 'dict[str, JsonValue]'


def jsonable(obj: object) -> JsonValue:
    """``obj`` as JSON data: a dataclass becomes the mapping of its fields (recursively; a field whose metadata
    says ``json: inline``, a mapping, gives its keys instead of a key of its own), numpy arrays and scalars become
    lists and numbers, tuples become lists. This is the one schema of ``--json``.

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
    json.dump(data, sys.stdout, allow_nan=False)
    sys.stdout.write('\n')
