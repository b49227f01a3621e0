"""The workspace models under their former module name (they live in :mod:`gpr_kinematics.workspace`)."""

from .workspace.dextar import DextarModel
from .workspace.gpr import GprModel
from .workspace.loader import MODEL_TYPES, load_workspace_model, model_from_mapping
from .workspace.planar import Rrr3PlanarModel
from .workspace.shell_arm import ShellArmModel
from .workspace.tripod import TripodModel
from .workspace.upu3 import Upu3Model

__all__ = [
    'MODEL_TYPES',
    'DextarModel',
    'GprModel',
    'Rrr3PlanarModel',
    'ShellArmModel',
    'TripodModel',
    'Upu3Model',
    'load_workspace_model',
    'model_from_mapping',
]
