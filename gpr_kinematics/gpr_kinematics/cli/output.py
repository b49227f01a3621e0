"""What the ``gpr`` subcommands print: ``--json`` is the result dataclass itself (:func:`jsonable`), one object."""
from __future__ import annotations

import dataclasses
import json
import sys
from typing import Any

import numpy as np


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
