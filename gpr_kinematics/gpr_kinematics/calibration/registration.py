"""The registration a calibration in a measuring frame reports (:class:`Registration`): the pose of ``gpr_base`` in
that frame and of the target in ``gpr_platform`` (:class:`~.frames.FramedModel`), their standard errors, and the
values the frames' datum gives its derived parameters, with their standard errors by the chain rule and the bias the
held parameters can cause them (Box & Draper, 1987, §10.2). Units: metres and radians."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .frames import FramedModel, Transform
from .quality import HeldBias

Array = NDArray[np.float64]

#: A coefficient of ``follow`` below this share of its row's largest is a rounding's, not a tie of a derived
#: parameter to a fitted one (:func:`registration`).
FOLLOW_ROUNDING = 1e-9


@dataclass(frozen=True)
class Registration:
    """The frames of a calibration from measurements in the frame ``frame``: the pose of ``gpr_base`` in it and of
    the target in ``gpr_platform``, with the standard errors of what was identified (position [m], then the
    rotation vector [rad] about the parent's axes; ``None``: given as known, or a held part ``nan``), the datum
    that fixes the frames and the values the datum gives its parameters (name -> value, standard error, unit), with
    the bias the held parameters can cause them (name -> worst case, standard deviation, the held parameter causing
    most of it; :meth:`~.quality.HeldBias.of`)."""

    frame: str
    base: Transform
    base_se: Array | None
    target: Transform
    target_se: Array | None
    datum: str
    derived: dict[str, tuple[float, float, str]]
    points: bool = False
    derived_bias: dict[str, tuple[float, float, str]] = field(default_factory=dict)
    #: The derived parameters that follow held parameters only (held too: no standard error).
    held: frozenset[str] = frozenset()

    def as_dict(self) -> dict[str, object]:
        def se(a: Array | None) -> list[float | None] | None:
            return None if a is None else [float(x) if np.isfinite(x) else None for x in a]
        def bias(name: str) -> dict[str, float | str | None]:
            b, sd, source = self.derived_bias.get(name, (math.nan, math.nan, ''))
            return {'bias': b if math.isfinite(b) else None, 'bias_std': sd if math.isfinite(sd) else None,
                    'bias_from': source or None}
        return {'frame': self.frame, 'base': self.base.as_dict() | {'standard_error': se(self.base_se)},
                'target': self.target.as_dict() | {'standard_error': se(self.target_se)}, 'datum': self.datum,
                'derived': {k: {'value': v, 'standard_error': s if math.isfinite(s) else None, 'unit': u,
                                'status': 'held' if k in self.held else 'derived'} | bias(k)
                            for k, (v, s, u) in self.derived.items()}}

    def _bias(self, name: str, unit: str) -> str:
        """`` bias <= 1.234 um (rod2_y)`` of a derived parameter the held ones can bias (empty otherwise)."""
        b, _, source = self.derived_bias.get(name, (math.nan, math.nan, ''))
        return f' bias <= {b * 1e6:.3f} {"um" if unit == "m" else "urad"} ({source})' if math.isfinite(b) and source \
            else ''

    def lines(self) -> list[str]:
        """The registration in words (the report's and the calibrated file's)."""
        out = []
        for what, t, se in ((f'gpr_base in {self.frame}', self.base, self.base_se),
                            ('the target in gpr_platform', self.target, self.target_se)):
            p, r = ', '.join(f'{x:.9f}' for x in t.position), ', '.join(f'{x:.9f}' for x in t.rpy)
            if se is None:
                out.append(f'{what}: position ({p}) m, rpy ({r}) rad (given)')
                continue
            sp = ', '.join(f'{x * 1e6:.3g}' for x in se[:3])
            sr = f' +- ({", ".join(f"{x * 1e6:.3g}" for x in se[3:])}) urad about its parent\'s axes' if se.size > 3 \
                else ' (a point: no orientation)' if self.points else ' (orientation given)'
            out.append(f'{what}: position ({p}) m +- ({sp}) um, rpy ({r}) rad{sr}')
        if self.datum:
            fixed = ', '.join((f'{k} {v:+.9g} (held: it follows held parameters)' if k in self.held
                               else f'{k} {v:+.9g} +- {s * 1e6:.3g} {"um" if u == "m" else "urad"}') + self._bias(k, u)
                              for k, (v, s, u) in self.derived.items())
            out.append(f'datum: {self.datum} ({fixed})')
        return out


def registration(model: FramedModel, estimate: Array, standard_error: Array, fitted: NDArray[np.int64],
                 covariance: Array, frame: str, bias: HeldBias | None = None) -> Registration:
    """The :class:`Registration` of an identification with ``model`` (its estimate, standard errors, fitted
    indices and their covariance, and the bias the held parameters can cause: the derived parameters' by the
    chain rule, ``theta_D = nominal_D + follow (theta_I - nominal_I)``)."""
    base, target = model.frames(estimate)
    names = model.parameters.names

    def se(stem: str, on: bool) -> Array | None:
        return np.array([standard_error[names.index(n)] for n in names if n.startswith(stem)]) if on else None

    derived, derived_bias, held = {}, {}, frozenset[str]()
    if model.dependent.size:
        full = model.inner_theta(np.asarray(estimate, dtype=float)[None])[0]
        cov = np.zeros((model.n_inner, model.n_inner))
        inner = fitted[fitted < model.n_inner]
        k = np.flatnonzero(fitted < model.n_inner)
        if covariance.shape == (fitted.size, fitted.size):
            cov[np.ix_(inner, inner)] = covariance[np.ix_(k, k)]
        else:   # a fit whose model cannot be evaluated where it ended has no covariance (an IndexError: a traceback)
            cov[np.ix_(inner, inner)] = math.nan
        var = np.einsum('di,ij,dj->d', model.follow, cov, model.follow)
        # A derived parameter that follows held parameters only is held too: no standard error (it read +- 0, and
        # +- 3e-14 um where a coefficient of a fitted one was a rounding's 1e-17 beside the held ones' 1)
        F = np.abs(model.follow)
        ties = F[:, inner] > FOLLOW_ROUNDING * np.max(F, axis=1, initial=0.0)[:, None]
        moves = np.any(ties, axis=1) if inner.size else np.zeros(var.shape, dtype=bool)
        ps = model.inner.parameters
        derived = {ps[int(j)].name: (float(full[j]), float(np.sqrt(max(v, 0.0))) if m else math.nan, ps[int(j)].unit)
                   for j, v, m in zip(model.dependent, var, moves, strict=True)}
        held = frozenset(name for name, m in zip(derived, moves, strict=True) if not m)
        if bias is not None:   # d theta_D / d theta: follow on the inner coordinates, nothing on the frames'
            G = np.hstack([model.follow, np.zeros((model.dependent.size, len(names) - model.n_inner))])
            worst, sd, source = bias.of(G)
            derived_bias = {name: (float(b), float(s), src)
                            for name, b, s, src in zip(derived, worst, sd, source, strict=True)}
    return Registration(frame, base, se('base_', model.fit_base), target, se('target_', model.fit_target is not None),
                        model.datum_text, derived, model.points, derived_bias, held)
