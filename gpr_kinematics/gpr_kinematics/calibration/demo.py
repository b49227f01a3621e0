"""The calibration step of ``make demo``: calibrate from the shipped synthetic measurement file, print the
residuals before and after, the identified values against the machine that made the file, and the accuracy
budget of a few stations from the shipped tolerance table, before and after calibration.

``python -m gpr_kinematics.calibration.demo`` (``--write-measurements PATH`` regenerates the shipped file).

The shipped file ``config/calibration/synthetic_measurements.csv`` holds :data:`ROWS` poses of a GPR whose
geometry differs from the nominal ``config/gpr.yaml`` by :data:`TRUE_DEVIATIONS` (rod base points and zero offsets
off by tens of micrometres, rods tilted by about 0.1 mrad, platform joints moved tangentially by tens of
micrometres) with joints of stiffness ratio :data:`TRUE_KAPPA` (the nominal file says 1000), under the compliant
model, at the configurations of ``gpr calibrate --plan 40``, with tracker noise :data:`SIGMA_POSITION`,
:data:`SIGMA_ANGLE` (seed :data:`SEED`). It is synthetic: made by this module from the core's own forward
kinematics, documented as such in its header.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..core.config import load_config
from ..errors import GprError
from ..inputs.resources import config_path
from .budget import accuracy_budget
from .core_model import CoreModel, write_calibrated_config
from .identification import identify
from .measurements import Measurements, read_measurements, write_measurements
from .plan import plan_measurements
from .report import format_budget, format_calibration
from .synthetic import synthetic_measurements
from .tolerances import load_tolerances

MEASUREMENTS = 'calibration/synthetic_measurements.csv'
TOLERANCES = 'calibration/tolerances_example.yaml'
#: The machine of the shipped file: deviations of its geometry from the nominal one [m, rad] (every parameter not
#: named is nominal); the joints move tangentially (joint k along (-sin theta_k, cos theta_k)), the radial places
#: of the joints being what these poses cannot see (docs/calibration.md).
TRUE_DEVIATIONS = {'rod1_x': 2.0e-5, 'rod1_y': -1.5e-5, 'rod2_x': -2.5e-5, 'rod3_y': 3.0e-5,
                   'rod1_offset': 4.0e-5, 'rod2_offset': -2.5e-5, 'rod3_offset': 1.5e-5,
                   'rod1_ux': 1.0e-4, 'rod2_uy': -1.2e-4, 'rod3_ux': -8.0e-5, 'rod3_uy': 6.0e-5,
                   'joint1_y': 2.0e-5, 'joint2_x': 1.2990381056766580e-5, 'joint2_y': 7.5e-6,
                   'joint3_x': -1.7320508075688773e-5, 'joint3_y': 1.0e-5}
#: Stiffness ratio k_t / k_r of the machine's joints.
TRUE_KAPPA = 3.0
ROWS = 40
SIGMA_POSITION = 3e-6
SIGMA_ANGLE = 2e-5
SEED = 12
#: Stations of the budget: height [m], tilt [rad], azimuth [rad].
STATIONS = ((0.45, 0.0262, 0.785), (0.10, 0.0349, 1.571))
BUDGET_SAMPLES = 1000


def true_values(model: CoreModel) -> np.ndarray:
    """The parameter values of the machine of the shipped file (module docstring)."""
    ps = model.parameters
    values = ps.values(ps.nominal)
    for name, deviation in TRUE_DEVIATIONS.items():
        values[ps.index(name)] += deviation
    for k in (1, 2, 3):
        values[ps.index(f'kappa{k}')] = TRUE_KAPPA
    return values


def shipped_measurements() -> Measurements:
    """The measurements of the shipped file, made afresh (module docstring)."""
    cfg = load_config()
    model = CoreModel(cfg)
    plan = plan_measurements(model, cfg, ROWS, sigma_position=SIGMA_POSITION, sigma_angle=SIGMA_ANGLE)
    truth = model.parameters.coordinates(true_values(model))
    return synthetic_measurements(model, truth, plan.q, SIGMA_POSITION, SIGMA_ANGLE, seed=SEED,
                                  source=MEASUREMENTS)


def header() -> tuple[str, ...]:
    dev = ', '.join(f'{n} {d:+.6g}' for n, d in TRUE_DEVIATIONS.items())
    return ('SYNTHETIC measurements for the calibration demonstration (gpr_kinematics.calibration.demo), not a real '
            'machine:', 'poses of gpr_platform in gpr_base from the core forward kinematics (model compliant) of a '
            f'GPR off the nominal config/gpr.yaml by {dev} (m, rad), with kappa = {TRUE_KAPPA:g} at every joint,',
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


def equivalent_truth(model: CoreModel, res: object) -> np.ndarray:
    """The true machine's values moved along the combinations the poses cannot see (the identifiability report's,
    which change no pose) until the parameters held for them are where the fit held them (nominal, or a platform
    joint on its rod): the machine the identification can find."""
    from .identification import CalibrationResult
    assert isinstance(res, CalibrationResult)
    ps = model.parameters
    truth = ps.coordinates(true_values(model))
    combos = res.identifiability.combinations
    if not combos:
        return ps.values(truth)
    V = np.zeros((len(ps), len(combos)))                     # the combinations in coordinates (their scales)
    for i, c in enumerate(combos):
        for name, coef in c.coefficients.items():
            V[ps.index(name), i] = coef * ps[ps.index(name)].scale
    held = [ps.index(c.held) for c in combos]
    shift = np.linalg.solve(V[held], res.estimate[held] - truth[held])
    return ps.values(truth + V @ shift)


def _against_truth(model: CoreModel, res: object) -> list[str]:
    """Per parameter: the true deviation (of :func:`equivalent_truth`) and the identified one with its standard
    error (in um, urad, or the value for kappa), or that it was held."""
    from .identification import CalibrationResult
    assert isinstance(res, CalibrationResult)
    ps = model.parameters
    nominal, truth = ps.values(ps.nominal), equivalent_truth(model, res)
    lines = []
    for j, p in enumerate(ps):
        f, u = {'m': (1e6, 'um'), 'rad': (1e6, 'urad'), '1': (1.0, '')}[p.unit]
        true = truth[j] if p.transform else truth[j] - nominal[j]
        text = f'  {p.name:<12} true {true * f:+9.3f} {u:<4}'
        if res.status[j] == 'fitted':
            est = res.values[j] if p.transform else res.values[j] - nominal[j]
            se = res.value_standard_error[j]
            text += f' identified {est * f:+9.3f} +- {se * f:.3f} {u:<4} ({(est - true) / se:+.2f} standard errors)'
        else:
            text += ' held at nominal (these poses cannot tell it from the other parameters)'
        lines.append(text)
    return lines


#: Configurations of the prediction check (random, within the stroke and the tilt limit), and their seed.
CHECK_POSES = 500


def _prediction_check(model: CoreModel, theta: np.ndarray) -> str:
    """How far the nominal and the calibrated model put the platform from where the true machine puts it, at
    :data:`CHECK_POSES` random configurations: what a calibration is for, and blind to the combinations the poses
    cannot separate (which change no pose)."""
    from ..core import naive_inverse
    from .model import evaluate, pose_error
    rng = np.random.default_rng(SEED)
    cfg = model.config
    Q = naive_inverse(rng.uniform(0.05, 0.45, CHECK_POSES), rng.uniform(0.0, 0.99, CHECK_POSES) * cfg.tilt_limit,
                      rng.uniform(-np.pi, np.pi, CHECK_POSES), cfg)
    truth = evaluate(model, model.parameters.coordinates(true_values(model)), Q)
    out = []
    for label, th in (('nominal', model.parameters.nominal), ('calibrated', theta)):
        e = pose_error(*evaluate(model, th, Q), *truth)
        dp, da = np.linalg.norm(e[:, :3], axis=1), np.linalg.norm(e[:, 3:], axis=1)
        out.append(f'{label} model {np.sqrt(np.mean(dp ** 2)) * 1e6:.3f} um RMS, {dp.max() * 1e6:.3f} um worst, '
                   f'{np.sqrt(np.mean(da ** 2)) * 1e6:.3f} urad RMS')
    return (f'prediction of the true machine\'s platform pose at {CHECK_POSES} random configurations: '
            + '; '.join(out))


def run() -> None:
    cfg = load_config()
    model = CoreModel(cfg)
    path = config_path(MEASUREMENTS)
    meas = read_measurements(path)
    table = load_tolerances(config_path(TOLERANCES))
    print(f'== calibration from {path} (synthetic: {ROWS} poses of a perturbed GPR, tracker noise '
          f'{SIGMA_POSITION * 1e6:g} um, {SIGMA_ANGLE * 1e6:g} urad)')
    res = identify(model, meas)
    print(format_calibration(res))
    print('against the machine that made the file (moved along the combinations above, which change no pose):')
    print('\n'.join(_against_truth(model, res)))
    print(_prediction_check(model, res.estimate))
    with tempfile.TemporaryDirectory() as tmp:
        out = write_calibrated_config(Path(tmp) / 'calibrated.yaml', model.config_for(res.estimate))
        back = load_config(out)
        print(f'calibrated geometry: written to a temporary {out.name} and read back (model {back.model}, kappa '
              f'{", ".join(f"{k:.4g}" for k in back.kappa)}), not kept: gpr calibrate MEASUREMENTS --output FILE '
              'writes one for --config')
    st = np.array(STATIONS)
    from ..core import inverse_batch
    Q = inverse_batch(st[:, 0], st[:, 1], st[:, 2], cfg).q
    labels = [f'{i + 1} (h {h:g} m, tilt {np.degrees(t):.2f} deg)' for i, (h, t, _) in enumerate(STATIONS)]
    print(f'\n== accuracy budget from {config_path(TOLERANCES).name}, before calibration')
    before = accuracy_budget(model, Q, table, tool=(0.3, 0.0, 0.1), samples=BUDGET_SAMPLES, labels=labels)
    print(format_budget(before))
    print('\n== the same after this calibration (the calibrated parameters known to their covariance, the held ones '
          'compensated through them)')
    # res.bias.alias is how the fitted estimates move with the value a held parameter is held at: -A of a deviation
    after = accuracy_budget(model, Q, table, tool=(0.3, 0.0, 0.1), samples=BUDGET_SAMPLES, labels=labels,
                            theta=res.estimate,
                            calibrated=(res.fitted, res.covariance, (res.bias.held, -res.bias.alias)))
    print(format_budget(after))


if __name__ == '__main__':
    sys.exit(main())
