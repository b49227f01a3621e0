"""The GPR's geometry as named scalars: the parameter table calibration fits and its covariance names.

Per rod ``k`` the base point ``B_k = (x, y)``, the zero offset ``o_k`` and the direction ``u_k``'s components, per
joint its platform position ``p_k = (x, y)`` and stiffness ratio ``kappa_k`` (Bratovanov & Sotirov, eq. (1)): 24
scalars, each with the geometry file's key it comes from (:data:`PARAMETERS`). The machine
(:mod:`gpr_kinematics.core.machine`) turns a config into this vector and back; a covariance block
(:mod:`gpr_kinematics.core.geometry_covariance`) names its rows by :data:`PARAMETER_NAMES`.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class GeometryParameter:
    """One scalar of the geometry file: its name in the parameter vector, the config key and position in it,
    the unit (``m``, ``rad`` for the small rod tilts, ``1`` for a ratio) and what it is."""

    name: str
    key: str
    rod: int
    component: int
    unit: str
    description: str


def _parameters() -> tuple[GeometryParameter, ...]:
    out = []
    for k in range(3):
        n = k + 1
        out += [GeometryParameter(f'rod{n}_x', 'rod_positions', k, 0, 'm', f'x of the base point B_{n} of rod {n}'),
                GeometryParameter(f'rod{n}_y', 'rod_positions', k, 1, 'm', f'y of the base point B_{n} of rod {n}'),
                GeometryParameter(f'rod{n}_offset', 'rod_offsets', k, 0, 'm', f'zero offset o_{n} of rod {n}'),
                GeometryParameter(f'rod{n}_ux', 'rod_directions', k, 0, 'rad',
                                  f'x component of the direction u_{n} of rod {n} (its tilt towards +x)'),
                GeometryParameter(f'rod{n}_uy', 'rod_directions', k, 1, 'rad',
                                  f'y component of the direction u_{n} of rod {n} (its tilt towards +y)'),
                GeometryParameter(f'joint{n}_x', 'platform_joints', k, 0, 'm', f'x of the platform joint p_{n}'),
                GeometryParameter(f'joint{n}_y', 'platform_joints', k, 1, 'm', f'y of the platform joint p_{n}'),
                GeometryParameter(f'kappa{n}', 'kappa', k, 0, '1',
                                  f'k_t / k_r of joint {n} (the compliant model only)')]
    return tuple(out)


#: The geometry as a parameter vector (24 scalars): per rod its base point, zero offset and direction, per joint
#: its platform position and stiffness ratio. Every other config value (stroke, limits, model) is not a parameter.
PARAMETERS: tuple[GeometryParameter, ...] = _parameters()
PARAMETER_NAMES: tuple[str, ...] = tuple(p.name for p in PARAMETERS)
#: The geometry file's keys the parameters are made of: their own, and ``radius`` and ``rod_azimuths``, which place
#: the rods where ``rod_positions`` is null (the nominal machine).
PARAMETER_KEYS: frozenset[str] = frozenset({p.key for p in PARAMETERS} | {'radius', 'rod_azimuths'})
