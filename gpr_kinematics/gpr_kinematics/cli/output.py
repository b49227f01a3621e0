"""What the ``gpr`` subcommands print and write: ``--json`` is the result dataclass itself (:func:`jsonable`), one
object; an output file is never one of the command's inputs (:func:`distinct_outputs`)."""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
from typing import Any

import numpy as np

from ..errors import InputError

#: The options (argparse ``dest``) that name a file or folder a subcommand writes.
OUTPUT_OPTIONS = ('output', 'csv', 'boxes', 'plot', 'waypoints', 'samples', 'report')


def jsonable(obj: Any) -> Any:
    """``obj`` as JSON data: a dataclass becomes the mapping of its fields (recursively), numpy arrays and
    scalars become lists and numbers, tuples become lists. This is the one schema of ``--json``."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    return obj


def emit_json(obj: Any) -> None:
    """Print ``obj`` (:func:`jsonable`) as one JSON object on stdout."""
    json.dump(jsonable(obj), sys.stdout, allow_nan=False)
    sys.stdout.write('\n')


def _existing(value: Any) -> list[str]:
    values = value if isinstance(value, list) else [value]
    return [v for v in values if isinstance(v, str) and v and os.path.exists(v)]


def distinct_outputs(args: argparse.Namespace) -> None:
    """Refuse, before any work, an output (:data:`OUTPUT_OPTIONS`) that names an existing file or folder the command
    also takes as an input, or another output (``gpr calibrate M.csv --output M.csv`` overwrote the measurements
    with the calibrated geometry). Files the command reads without naming them (a robot's geometry file) are
    refused when written (:func:`gpr_kinematics.inputs.files.check_output`)."""
    values = vars(args)
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
                raise InputError(f'--{key} {out!r} is the same file as {other.upper()} {path!r} ({what}); allowed: '
                                 'an output that is none of the files the command reads or writes')
