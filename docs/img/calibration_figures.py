"""Regenerate the figures of docs/calibration.md: ``python docs/img/calibration_figures.py`` (from the repository
root; needs the ``plot`` extra, matplotlib).

* ``calibration_residuals.png``: the residuals of the demonstration's calibration (the shipped synthetic
  measurements) before and after, as ``gpr calibrate gpr_kinematics/config/calibration/synthetic_measurements.csv
  --output calibrated.yaml --plot calibration_residuals.png`` draws them (the calibrated file goes to a temporary
  folder);
* ``accuracy_budget.png``: the accuracy budget of the documented example, ``gpr accuracy gpr.yaml --tolerances
  gpr_kinematics/config/calibration/tolerances_example.yaml --pose 0 0 0.5 0.0349 0 0 --tool 0.3 0 0.1 --plot
  accuracy_budget.png`` (its printed budget discarded).

This script runs those commands.
"""
import contextlib
import io
import tempfile
from pathlib import Path

from gpr_kinematics.cli.main import main as gpr
from gpr_kinematics.inputs.resources import config_path

OUT = Path(__file__).resolve().parent
#: The arguments of the documented budget (docs/calibration.md, "gpr accuracy"), the table given by its path.
BUDGET = ['accuracy', 'gpr.yaml', '--tolerances', str(config_path('calibration/tolerances_example.yaml')), '--pose',
          '0', '0', '0.5', '0.0349', '0', '0', '--tool', '0.3', '0', '0.1']


def main() -> None:
    shipped = str(config_path('calibration/synthetic_measurements.csv'))
    with tempfile.TemporaryDirectory() as tmp:
        status = gpr(['calibrate', shipped, '--output', str(Path(tmp) / 'calibrated.yaml'), '--no-progress',
                      '--plot', str(OUT / 'calibration_residuals.png')])
    if status != 0:
        raise SystemExit(f'gpr calibrate exited with status {status}')
    with contextlib.redirect_stdout(io.StringIO()):
        status = gpr([*BUDGET, '--no-progress', '--plot', str(OUT / 'accuracy_budget.png')])
    if status != 0:
        raise SystemExit(f'gpr accuracy exited with status {status}')


if __name__ == '__main__':
    main()
