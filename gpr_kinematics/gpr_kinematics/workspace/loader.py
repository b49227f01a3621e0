"""Workspace models from mechanism YAML files: every ``type`` the package covers.

:data:`BUILDERS` is the table of :mod:`gpr_kinematics.workspace.builders` (the papers' mechanisms) with the
equation-defined models (:mod:`.equations`) and the joint working area (:mod:`.joint_area`), which builds its two
mechanisms with the first table.
"""
from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..mechanisms import read_mechanism_file
from . import builders, equations, joint_area

#: ``type`` -> (builder, extra keys of its ``workspace:`` section): every model the package covers.
BUILDERS: dict[str, tuple[builders.Builder, tuple[str, ...]]] = {
    **builders.BUILDERS,
    'equations': (equations.from_mapping, ()),
    'joint_working_area': (joint_area.from_mapping, ()),
}
MODEL_TYPES = tuple(BUILDERS)


def model_from_mapping(data: Any, source: str = 'mechanism', overrides: Mapping[str, Any] | None = None) -> Any:
    """The workspace model of a mechanism description of any type (:func:`builders.model_from_mapping`)."""
    return builders.model_from_mapping(data, source, overrides, BUILDERS)


def load_workspace_model(path: str | Path, overrides: Mapping[str, Any] | None = None) -> Any:
    """Read a mechanism YAML file (``type`` key, SI parameters, optional ``workspace:`` section)."""
    data, p = read_mechanism_file(path)
    return model_from_mapping(data, str(p), overrides)
