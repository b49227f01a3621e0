"""Text reports of the calibration's results (the ``gpr calibrate`` output and the demonstration).

Every number printed is a field of the result's ``as_dict()`` (the JSON), converted to micrometres or
microradians where the unit says so; the tests parse the text back and compare it with the JSON.
"""
from __future__ import annotations

import math

import numpy as np

from .budget import QUANTITIES, Budget
from .measurements import row_name
from .plan import MeasurementPlan
from .quality import CV_GATE
from .results import CalibrationResult, ResidualStats


def micro(value: float, unit: str) -> str:
    """``value`` in micro-units with its unit (``um``, ``urad``), or as is for a dimensionless value."""
    if unit == 'm':
        return f'{value * 1e6:+.3f} um'
    if unit == 'rad':
        return f'{value * 1e6:+.3f} urad'
    return f'{value:+.6g}'


def _residual_row(label: str, r: ResidualStats) -> str:
    """One row of the residuals' table: a space before every number (87659.617 um195626.998 um ran together), '-'
    where there is none (a cross-validation without a row to leave out printed ``nan um ... (line 0)``)."""
    angle = (f' {r.rms_angle * 1e6:9.3f} urad {r.max_angle * 1e6:9.3f} urad '
             f'({row_name(r.worst_angle_line, r.worst_angle_file)})' if math.isfinite(r.rms_angle)
             else f'{"-":>15}{"-":>25}')
    if not math.isfinite(r.rms_position):
        return f'  {label:<10}{"-":>13}{"-":>24}{angle}'
    return (f'  {label:<10} {r.rms_position * 1e6:9.3f} um {r.max_position * 1e6:9.3f} um '
            f'({row_name(r.worst_position_line, r.worst_position_file)}){angle}')


def _bias(res: CalibrationResult, j: int, unit: str) -> str:
    """``  bias <= 1.234 um (rod3_x)`` for a fitted parameter the held ones can bias (empty otherwise)."""
    b = res.value_bias[j]
    if res.status[j] != 'fitted' or not math.isfinite(b) or not res.bias.source[j]:
        return ''
    return f'  bias <= {micro(b, unit).lstrip("+")} ({res.bias.source[j]})'


def _checks(res: CalibrationResult) -> list[str]:
    """The fit's convergence, its starts, the cross-validation and the gate."""
    c, cv = res.convergence, res.cross_validation
    starts = ', '.join(f'{s.label} {s.chi2_reduced:.4g} ({s.status})' for s in c.starts)
    bound = f'; at a bound of their range: {", ".join(c.at_bound)}' if c.at_bound else ''
    lines = [f'fit: {c.status} (Gauss-Newton step left {c.step_se:.2g} standard errors){bound}; reduced chi-square '
             f'from each start: {starts}',
             f'cross-validation (each row predicted by the fit of the others): ratio {cv.ratio:.3g} to what the '
             f'fit\'s residuals predict (gate {CV_GATE:g})' if math.isfinite(cv.ratio) else
             'cross-validation: none (each row alone determines a fitted combination: no row can be left out)']
    if cv.alone:
        alone = (', '.join(row_name(ln, f) for ln, f in zip(cv.alone, cv.alone_files, strict=True))
                 if cv.alone_files else 'line(s) ' + ', '.join(map(str, cv.alone)))
        lines.append(f'  {alone} alone determine a fitted combination: no other row '
                     'checks them')
    if res.gate.passed:
        passed = [f'{g.name.replace("_", " ")} {g.value:.3g} {">=" if g.at_least else "<="} {g.limit:.3g}'
                  if g.judged else f'{g.name.replace("_", " ")} not judged'
                  for g in res.gate.checks if g.name not in ('minimum', 'identified')]
        lines.append('gate: passed (' + ', '.join(passed) + ', minimum reached)')
        lines += [f'  {g.detail}' for g in res.gate.checks if not g.judged]
    else:
        lines.append(f'gate: FAILED: {res.gate.message()}')
    return lines


def format_calibration(res: CalibrationResult) -> str:
    """Identified parameters with standard errors and the bias the held ones can cause, residuals before, after and
    cross-validated, identifiability, the fit's chi-square, convergence and gate."""
    ident = res.identifiability
    lines = [f'calibration from {res.source}: {res.rows} rows, {len(ident.names)} free parameter(s), '
             f'{len(ident.identified)} fitted in {res.iterations} Levenberg-Marquardt iterations',
             f'  {"parameter":<14}{"nominal":>19}{"estimate":>20}{"change":>17}{"std error":>16}  status']
    nominal, values, se_v = res.parameters.values(res.parameters.nominal), res.values, res.value_standard_error
    for j, p in enumerate(res.parameters):
        se = se_v[j]
        se_txt = micro(se, p.unit).lstrip('+') if math.isfinite(se) else '-'
        lines.append(f'  {p.name:<14} {nominal[j]:>18.12g} {values[j]:>19.12g} '
                     f'{micro(values[j] - nominal[j], p.unit):>16} {se_txt:>15}  {res.status[j]} [{p.unit}]'
                     f'{_bias(res, j, p.unit)}')
    lines.append(f'  {"residuals":<10}{"RMS position":>13}{"worst position":>24}{"RMS angle":>15}'
                 f'{"worst angle":>25}')
    lines.append(_residual_row('before', res.before))
    lines.append(_residual_row('after', res.after))
    lines.append(_residual_row('left out', res.cross_validated))
    sv = ' '.join(f'{s:.4g}' for s in ident.singular_values)
    lines.append(f'identifiability: scaled singular values {sv} (bound {ident.threshold:.3g})')
    if ident.combinations:
        lines += [f'  {c.describe()}' for c in ident.combinations]
    else:
        lines.append('  every free parameter is identified')
    if ident.identified:
        lines.append(f'  condition number of the fitted parameters {ident.condition_number:.4g}')
    lines.append(f'reduced chi-square {res.chi2_reduced:.4g} ({_noise(res)})')
    return '\n'.join(lines + _checks(res) + [f'warning: {w}' for w in res.warnings])


def _noise(res: CalibrationResult) -> str:
    """Which sigmas are the noise (the file's or the options') and which are assumed, in words."""
    if res.absolute_sigma:
        return 'sigmas from the file or --sigma-position/--sigma-angle: the noise'
    if not res.declared:
        return ('no noise declared: the sigmas used are the assumed noise, standard errors scaled by each kind\'s own '
                'reduced chi-square (positions, angles)')
    kind = res.declared[0]
    other = 'angle' if kind == 'position' else 'position'
    return (f'the {kind}s\' sigmas declared (the file\'s sigma_{kind} or --sigma-{kind}): their noise, checked by the '
            f'gate\'s sigmas check; the {other}s\' assumed: their standard errors scaled by the {other}s\' own reduced '
            'chi-square')


def format_plan(plan: MeasurementPlan, sigma_position: float, sigma_angle: float) -> str:
    """The planned configurations, the observability index against random designs, the predicted errors."""
    n = plan.q.shape[0]
    lines = [f'measurement plan: {n} configuration(s) chosen from {plan.candidates} candidates within the stroke '
             f'and tilt limits ({plan.passes} exchange pass(es), {plan.exchanges} exchange(s))',
             f'  {"#":>3}{"q1 [m]":>12}{"q2 [m]":>12}{"q3 [m]":>12}{"height [m]":>12}{"tilt [deg]":>12}'
             f'{"azimuth [deg]":>15}']
    for i in range(n):
        lines.append(f'  {i + 1:>3}{plan.q[i, 0]:12.6f}{plan.q[i, 1]:12.6f}{plan.q[i, 2]:12.6f}'
                     f'{plan.height[i]:12.6f}{math.degrees(plan.tilt[i]):12.4f}{math.degrees(plan.azimuth[i]):15.2f}')
    lines.append(f'observability index ({plan.index_name}) {plan.index:.6g}; median of random designs of the same '
                 f'size {plan.random_index:.6g}')
    ident = plan.identifiability
    intervals = plan.intervals()
    coord = np.sqrt(np.diag(plan.covariance)) if plan.fitted.size else np.zeros(0)
    pred = []
    for j, s, c in zip(plan.fitted, plan.standard_errors, coord, strict=True):
        p = plan.parameters[int(j)]
        if p.name in intervals:   # a stiffness ratio: its anisotropy's error and the values it spans
            lo, hi = intervals[p.name]
            pred.append(f'{p.name} {c:.3g} in anisotropy ({p.name[:5]} {lo:.3g} .. {hi:.3g} about '
                        f'{float(p.value(plan.at[j])):.4g})')
        else:
            pred.append(f'{p.name} {micro(s, p.unit).lstrip("+")}')
    lines.append(f'predicted standard errors (sigma_position {sigma_position * 1e6:g} um, sigma_angle '
                 f'{sigma_angle * 1e6:g} urad): {", ".join(pred) or "none"}')
    lines += [f'  {c.describe()}' for c in ident.combinations]
    return '\n'.join(lines)


def format_budget(b: Budget, top: int = 3) -> str:
    """The budget: per station and quantity the linearised RSS and worst case and the Monte Carlo percentiles,
    in um (lengths) and urad (angles), and the ``top`` largest shares of each quantity's RSS."""
    pcols = ''.join(f'{"MC p" + format(p, "g"):>11}' for p in b.percentiles) if b.samples else ''
    lines = [f'accuracy budget: {len(b.labels)} station(s), errors in the axes of {b.frame}; '
             + (f'{b.samples} Monte Carlo samples (seed {b.seed})' if b.samples else 'linearised only')]
    if b.compensated:
        lines.append(f'held by the calibration, compensated through the calibrated parameters (its alias): '
                     f'{", ".join(b.compensated)}')
    for i, label in enumerate(b.labels):
        # the tool to 1 um, as q (its rounding, 1.22465e-17 m, read as an offset; no -0.000000)
        tool = ', '.join(f'{0.0 if abs(v) < 5e-7 else v:.6f}' for v in b.tool[i])
        lines.append(f'station {label}: q = ({b.q[i, 0]:.6f}, {b.q[i, 1]:.6f}, {b.q[i, 2]:.6f}) m, tool ({tool}) m in '
                     'gpr_platform')
        lines.append(f'  {"quantity":<20}{"unit":>5}{"RSS":>11}{"worst":>11}{pcols}  largest shares')
        for name, (_, unit) in QUANTITIES.items():
            u = 'um' if unit == 'm' else 'urad'
            cells = f'{b.rss[name][i] * 1e6:11.3f}{b.worst[name][i] * 1e6:11.3f}'
            if b.samples:
                cells += ''.join(f'{x * 1e6:11.3f}' for x in b.mc[name][i])
            # by share, ties (equal to 1e-9, rounding) by name: the same names on every numpy
            order = sorted(range(len(b.sources)), key=lambda j: (-round(float(b.shares[name][i, j]), 9),
                                                                  b.sources[j]))[:top]
            share = ', '.join(f'{b.sources[j]} {100 * b.shares[name][i, j]:.1f} %' for j in order
                              if b.shares[name][i, j] > 0)
            lines.append(f'  {name.replace("_", " "):<20}{u:>5}{cells}  {share}'.rstrip())
    lines += [f'warning: {w}' for w in b.warnings]
    return '\n'.join(lines)
