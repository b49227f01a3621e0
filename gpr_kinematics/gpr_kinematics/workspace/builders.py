"""Workspace models of the mechanisms' YAML mappings (``type`` key, SI parameters, optional ``workspace:`` section).

:data:`BUILDERS` builds the constraint models of the papers' mechanisms (tripod, planar 3-RRR, DexTAR, 3-UPU, GPR,
the shell arm); :func:`model_from_mapping` checks the ``workspace:`` section and builds any model of a table of
builders (:mod:`gpr_kinematics.workspace.loader` adds the equation-defined models and the joint working area).
Every number goes through :func:`gpr_kinematics.inputs.schema.number_key` (a finite int or float: no bool, no string)
and every mapping through :func:`gpr_kinematics.inputs.schema.check_keys` (unknown keys are refused with their
names), the rules of every YAML loader of the package.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, TypeVar

from ..errors import ConfigError, InputError, brief
from ..inputs.schema import check_keys, number_key
from ..mechanisms import MECHANISM_TYPES, mechanism_from_dict
from ..mechanisms.base import Mechanism
from ..mechanisms.gpr import GprMechanism
from ..mechanisms.tripod import Tripod3RPS
from ..mechanisms.upu3 import UPU3
from .base import WorkspaceModel
from .boxes import box_from, number
from .dextar import DextarModel
from .gpr import MAX_TILT, GprModel
from .planar import Rrr3PlanarModel
from .shell_arm import ShellArmModel
from .tripod import TripodModel
from .upu3 import Upu3Model

M = TypeVar('M', bound=Mechanism)
_COMMON = ('type', 'name', 'reference', 'workspace')
_WORKSPACE_KEYS = ('box', 'angle_scale')


def _mechanism(data: Mapping[str, Any], source: str, kind: type[M]) -> M:
    """The validated mechanism of ``data`` (its loader checks the keys), of the class ``kind`` its type names."""
    mech = mechanism_from_dict(data, source)
    if not isinstance(mech, kind):  # the mechanism types and their classes are one table
        raise ConfigError(f'{source}: type {brief(data.get("type"))} is not a {kind.__name__}')
    return mech


def _angles(data: Mapping[str, Any], key: str, default: Sequence[float], source: str) -> list[float]:
    value = data.get(key, default)
    if not isinstance(value, (list, tuple)) or len(value) != 3:
        raise ConfigError(f'{source}: {key} must be a list of 3 angles in rad, got {str(value)[:80]}')
    return [number(v, f'{key}[{i}]', source, unit='rad') for i, v in enumerate(value)]


def _tripod(data: Mapping[str, Any], ws: Mapping[str, Any], src: str, scale: float | None) -> WorkspaceModel:
    mech = _mechanism(data, src, Tripod3RPS)
    lo, hi = (float(v) for v in mech.joint_limits[0])
    return TripodModel(mech.base_radius, mech.platform_radius, lo, hi,
                       angle_scale=scale if scale is not None else mech.characteristic_length)


def _upu3(data: Mapping[str, Any], ws: Mapping[str, Any], src: str, scale: float | None) -> WorkspaceModel:
    mech = _mechanism(data, src, UPU3)
    lo, hi = (float(v) for v in mech.joint_limits[0])
    return Upu3Model(mech.b, mech.p, lo, hi, [float(a) for a in mech.azimuths])


def _planar(data: Mapping[str, Any], ws: Mapping[str, Any], src: str, scale: float | None) -> WorkspaceModel:
    check_keys(data, (*_COMMON, 'base_radius', 'platform_radius', 'crank', 'coupler', 'theta_min', 'theta_max',
                      'base_angles', 'platform_angles', 'branch'), src)
    branch = data.get('branch', 1)
    if isinstance(branch, bool) or branch not in (1, -1) or not isinstance(branch, int):
        raise ConfigError(f'{src}: branch must be 1 or -1 (the working mode), got {str(branch)[:40]}')
    return Rrr3PlanarModel(
        number_key(data, 'base_radius', src),
        number_key(data, 'platform_radius', src),
        number_key(data, 'crank', src),
        number_key(data, 'coupler', src),
        number_key(data, 'theta_min', src, -math.pi / 4, positive=False, unit='rad'),
        number_key(data, 'theta_max', src, math.pi / 4, positive=False, unit='rad'),
        _angles(data, 'base_angles', (math.pi / 2, 7 * math.pi / 6, 11 * math.pi / 6), src),
        None if 'platform_angles' not in data else _angles(data, 'platform_angles', (), src),
        branch,
        angle_scale=scale,
    )


def _dextar(data: Mapping[str, Any], ws: Mapping[str, Any], src: str, scale: float | None) -> WorkspaceModel:
    check_keys(data, (*_COMMON, 'la', 'lb', 'lc', 'ld', 'd'), src)
    la, lb, lc, ld = (number_key(data, k, src) for k in ('la', 'lb', 'lc', 'ld'))
    return DextarModel(la, lb, lc, ld, number_key(data, 'd', src, positive=False))


def _shell_arm(data: Mapping[str, Any], ws: Mapping[str, Any], src: str, scale: float | None) -> WorkspaceModel:
    check_keys(data, (*_COMMON, 'l1', 'l2', 'floor'), src)
    floor = number_key(data, 'floor', src, positive=False) if 'floor' in data else -math.inf
    return ShellArmModel(number_key(data, 'l1', src), number_key(data, 'l2', src), floor)


#: The GPR overrides its workspace model uses, with ``model`` (``radial`` only): ``gpr workspace`` refuses every other
#: (its stiffness, solver settings, tilt limit, an imperfect machine's geometry: accepted and ignored before); where a
#: command uses the mechanism and only checks its ``workspace:`` section (:func:`check_section`), the others are
#: left out.
GPR_NOMINAL = ('radius', 'rod_azimuths', 'stroke_min', 'stroke_max', 'imperfection_budget')


def _gpr(data: Mapping[str, Any], ws: Mapping[str, Any], src: str, scale: float | None) -> WorkspaceModel:
    """GPR parameters from the mechanisms interface (``type: gpr``, optional ``overrides`` of GprConfig)."""
    vj = ws.get('virtual_joint_model', 'radial')
    if vj != 'radial':
        raise ConfigError(f'{src}: workspace.virtual_joint_model {str(vj)[:40]!r} has no certified enclosure; '
                          'allowed: radial')
    cfg = _mechanism(data, src, GprMechanism).config
    if cfg.model != 'radial':  # the enclosure is radial's: another model's boxes would be called certified
        raise ConfigError(f'{src}: overrides model {cfg.model!r} has no certified enclosure; allowed: radial (the '
                          'workspace model is the radial model\'s)')
    unused = [str(k) for k in data.get('overrides') or {} if k not in (*GPR_NOMINAL, 'model')]
    if unused:
        raise ConfigError(f'{src}: {", ".join(unused)} in overrides: the GPR workspace model is of the nominal '
                          'machine (radius, rod azimuths, stroke, budget) and does not use them; allowed: those keys '
                          'only (radius, rod_azimuths, stroke_min, stroke_max, imperfection_budget; model: radial)')
    return GprModel(
        cfg.radius,
        tuple(float(a) for a in cfg.rod_azimuths),
        cfg.stroke_min,
        cfg.stroke_max,
        cfg.imperfection_budget,
        angle_scale=scale,
        max_tilt=number_key(ws, 'max_tilt', src, MAX_TILT, unit='rad'),
    )


Builder = Callable[[Mapping[str, Any], Mapping[str, Any], str, 'float | None'], Any]
#: ``type`` -> (builder, extra keys of its ``workspace:`` section).
BUILDERS: dict[str, tuple[Builder, tuple[str, ...]]] = {
    'tripod_3rps': (_tripod, ()),
    'rrr3_planar': (_planar, ()),
    'dextar': (_dextar, ()),
    'upu3': (_upu3, ()),
    'gpr': (_gpr, ('virtual_joint_model', 'max_tilt')),
    'shell_arm': (_shell_arm, ()),
}


def check_section(data: Mapping[str, Any], source: str) -> None:
    """The ``workspace:`` section of the mechanism file ``data`` checked as ``gpr workspace`` checks it, for a command
    that analyses the mechanism and does not use the section (a malformed box refused all the same): a GPR's overrides
    other than :data:`GPR_NOMINAL` are the command's to use, not the section's to refuse, and are left out."""
    overrides = data.get('overrides')
    if data.get('type') == 'gpr' and isinstance(overrides, Mapping):
        data = {**data, 'overrides': {k: v for k, v in overrides.items() if k in GPR_NOMINAL}}
    model_from_mapping(data, source)


def model_from_mapping(data: Any, source: str = 'mechanism', overrides: Mapping[str, Any] | None = None,
                       builders: Mapping[str, tuple[Builder, tuple[str, ...]]] = BUILDERS) -> Any:
    """Build the workspace model of a mechanism description (the YAML's mapping; SI units).

    ``type`` selects the model; the mechanism keys are read at the top level; the ``workspace:`` section may
    give ``box`` (variable -> [lower, upper]) and ``angle_scale`` (m per rad for the diameter).
    ``overrides`` replace top-level keys (e.g. ``{'b': 0.25}`` for the 3-UPU studies); ``builders`` maps each
    ``type`` to its builder and the extra keys of its ``workspace:`` section.
    """
    if not isinstance(data, Mapping):
        raise ConfigError(f'{source}: a mechanism file must be a YAML mapping with a "type" key')
    data = dict(data)
    if overrides:
        data.update(overrides)
    kind = data.get('type')
    if not isinstance(kind, str) or kind not in builders:
        what = f'unknown mechanism type {str(kind)[:40]!r}' if 'type' in data else 'no mechanism type (a key type)'
        if isinstance(kind, str) and kind in MECHANISM_TYPES:   # it was called unknown ('stewart_6sps')
            what = f'mechanism type {kind!r} has no workspace model'
        raise ConfigError(f'{source}: {what}; allowed: the types with a workspace model: {", ".join(builders)}')
    builder, extra = builders[kind]
    ws = data.get('workspace') or {}
    if not isinstance(ws, Mapping):
        raise ConfigError(f'{source}: the workspace section must be a mapping')
    src = f'{source} ({kind})'
    check_keys(ws, (*_WORKSPACE_KEYS, *extra), f'{src}: workspace')
    scale = None if ws.get('angle_scale') is None else number_key(ws, 'angle_scale', src)
    try:
        model = builder(data, ws, src, scale)
    except ConfigError as exc:   # a model's constructor names its type alone ('shell_arm: l1 = 3e-07; ...')
        text = str(exc)
        if text.startswith(source):
            raise
        raise ConfigError(f'{src}: {text.removeprefix(f"{kind}: ")}') from None
    if isinstance(model, WorkspaceModel):
        model.box = box_from(ws, model.variables, model.box, src)
        try:
            model.check_box(model.box)
        except InputError as exc:
            raise ConfigError(f'{src}: {exc}') from None
    return model


