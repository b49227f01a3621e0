"""Workspace (working area) approximation of parallel mechanisms by certified nonuniform covering.

One module per concept: :mod:`.base` (the constraint model and the result), :mod:`.covering` (the
level-by-level covering and its driver), :mod:`.scheduler` (one process or a Dask cluster), :mod:`.grid`
(the uncertified grid methods), :mod:`.boxes` (box arrays), the mechanisms' models (:mod:`.tripod`,
:mod:`.planar`, :mod:`.dextar`, :mod:`.upu3`, :mod:`.gpr`, :mod:`.shell_arm`), :mod:`.builders` and
:mod:`.loader` (YAML).
See docs/workspace.md.
"""

from .base import MAX_BOXES, WorkspaceModel, WorkspaceResult, default_max_boxes
from .boxes import box_volume, contains_points
from .covering import METHODS, approximate
from .loader import MODEL_TYPES, load_workspace_model, model_from_mapping

__all__ = [
    'MAX_BOXES',
    'METHODS',
    'MODEL_TYPES',
    'WorkspaceModel',
    'WorkspaceResult',
    'approximate',
    'box_volume',
    'contains_points',
    'default_max_boxes',
    'load_workspace_model',
    'model_from_mapping',
]
