"""The calibration step of ``make demo``: calibrate from the shipped synthetic measurement file, print the
residuals before and after, the identified values against the machine that made the file, and the accuracy
budget of a few stations from the shipped tolerance table, before and after calibration.

``python -m gpr_kinematics.calibration.demo`` (``--write-measurements PATH`` regenerates the shipped file).

The shipped file ``config/calibration/synthetic_measurements.csv`` holds :data:`ROWS` poses of a GPR whose
geometry differs from the nominal ``config/gpr.yaml`` by :data:`TRUE_DEVIATIONS` (a radius 40 um larger,
rod azimuths off by tenths of a milliradian: within the tolerances of the shipped table), at the
configurations of ``gpr calibrate --plan 24``, with tracker noise :data:`SIGMA_POSITION`, :data:`SIGMA_ANGLE`
(seed :data:`SEED`). It is synthetic: made by this module
from the core's own forward kinematics, documented as such in its header.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..config import load_config
from ..errors import GprError
from ..resources import config_path
from .budget import accuracy_budget
from .core_model import CoreModel, write_calibrated_config
from .identification import identify
from .measurements import Measurements, read_measurements, write_measurements
from .plan import plan_measurements
from .report import format_budget, format_calibration
from .synthetic import synthetic_measurements
from .tolerances import load_tolerances, prior_of

MEASUREMENTS = 'calibration/synthetic_measurements.csv'
TOLERANCES = 'calibration/tolerances_example.yaml'
#: The machine of the shipped file: deviations from the nominal geometry, SI, in the order of the parameters
#: (radius, rod_azimuth1, rod_azimuth2, rod_azimuth3).
TRUE_DEVIATIONS = (40e-6, 3e-4, -2e-4, 1e-4)
ROWS = 24
SIGMA_POSITION = 3e-6
SIGMA_ANGLE = 2e-5
SEED = 12
#: Stations of the budget: height [m], tilt [rad], azimuth [rad].
STATIONS = ((0.45, 0.0262, 0.785), (0.10, 0.0349, 1.571))
BUDGET_SAMPLES = 1000


def shipped_measurements() -> Measurements:
    """The measurements of the shipped file, made afresh (module docstring)."""
    cfg = load_config()
    model = CoreModel(cfg)
    plan = plan_measurements(model, cfg, ROWS, sigma_position=SIGMA_POSITION, sigma_angle=SIGMA_ANGLE)
    truth = model.parameters.nominal + np.array(TRUE_DEVIATIONS)
    return synthetic_measurements(model, truth, plan.q, SIGMA_POSITION, SIGMA_ANGLE, seed=SEED,
                                  source=MEASUREMENTS)


def header() -> tuple[str, ...]:
    dev = ', '.join(f'{n} {d:+.6g}' for n, d in zip(CoreModel(load_config()).parameters.names, TRUE_DEVIATIONS,
                                                       strict=True))
    return ('SYNTHETIC measurements for the calibration demonstration (gpr_kinematics.calibration.demo), not a real '
            'machine:', f'poses of gpr_platform in gpr_base from the core forward kinematics of a GPR off the nominal '
            f'config/gpr.yaml by {dev} (m, rad),',
            f'at the {ROWS} configurations of `gpr calibrate --plan {ROWS}`, with tracker noise {SIGMA_POSITION:g} m '
            f'and {SIGMA_ANGLE:g} rad (seed {SEED}).')


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--write-measurements', metavar='PATH', help='regenerate the shipped measurement file')
    args = ap.parse_args(argv)
    try:
        if args.write_measurements:
            write_measurements(args.write_measurements, shipped_measurements(), header())
            print(f'wrote {args.write_measurements}')
            return 0
        run()
    except GprError as exc:
        print(f'calibration demo: error: {exc}', file=sys.stderr)
        return 2
    return 0


def run() -> None:
    cfg = load_config()
    model = CoreModel(cfg)
    path = config_path(MEASUREMENTS)
    meas = read_measurements(path)
    table = load_tolerances(config_path(TOLERANCES))
    print(f'== calibration from {path} (synthetic: {ROWS} poses of a perturbed GPR, tracker noise '
          f'{SIGMA_POSITION * 1e6:g} um, {SIGMA_ANGLE * 1e6:g} urad), a-priori uncertainties from '
          f'{config_path(TOLERANCES).name}')
    res = identify(model, meas, prior=prior_of(table, model.parameters))
    print(format_calibration(res))
    print('against the machine that made the file:')
    for j, p in enumerate(model.parameters):
        f, u = (1e6, 'um') if p.unit == 'm' else (1e3, 'mrad')
        text = f'  {p.name:<14} true {TRUE_DEVIATIONS[j] * f:+9.3f} {u:<5}'
        if res.status[j] == 'fitted':
            err = (res.estimate[j] - p.nominal - TRUE_DEVIATIONS[j]) / res.standard_error[j]
            text += (f' identified {(res.estimate[j] - p.nominal) * f:+9.3f} +- {res.standard_error[j] * f:.3f} '
                     f'{u:<5} ({err:+.2f} standard errors)')
        else:
            text += ' held at nominal (these poses know it less well than its tolerance)'
        print(text)
    with tempfile.TemporaryDirectory() as tmp:
        out = write_calibrated_config(Path(tmp) / 'calibrated.yaml', model.config_for(res.estimate))
        print(f'calibrated geometry: a config file for --config (here {out.name}: radius '
              f'{load_config(out).radius:.9f} m)')
    st = np.array(STATIONS)
    from ..kinematics import inverse_batch
    Q = inverse_batch(st[:, 0], st[:, 1], st[:, 2], cfg).q
    labels = [f'{i + 1} (h {h:g} m, tilt {np.degrees(t):.2f} deg)' for i, (h, t, _) in enumerate(STATIONS)]
    print(f'\n== accuracy budget from {config_path(TOLERANCES).name}, before calibration')
    before = accuracy_budget(model, Q, table, tool=(0.3, 0.0, 0.1), samples=BUDGET_SAMPLES, labels=labels)
    print(format_budget(before))
    print('\n== the same after this calibration (the calibrated parameters known to their covariance)')
    after = accuracy_budget(model, Q, table, tool=(0.3, 0.0, 0.1), samples=BUDGET_SAMPLES, labels=labels,
                            theta=res.estimate, calibrated=(res.fitted, res.covariance))
    print(format_budget(after))


if __name__ == '__main__':
    sys.exit(main())
