"""Regenerate the figure of docs/calibration.md: ``python docs/img/calibration_figures.py`` (from the repository root;
needs the ``plot`` extra, matplotlib).

The residuals of the demonstration's calibration (the shipped synthetic measurements) before and after, as
``gpr calibrate gpr_kinematics/config/calibration/synthetic_measurements.csv --output calibrated.yaml --plot
calibration_residuals.png`` draws them: this script runs that command (the calibrated file goes to a temporary
folder).
"""
import tempfile
from pathlib import Path

from gpr_kinematics.cli.main import main as gpr
from gpr_kinematics.inputs.resources import config_path

OUT = Path(__file__).resolve().parent


def main() -> None:
    shipped = str(config_path('calibration/synthetic_measurements.csv'))
    with tempfile.TemporaryDirectory() as tmp:
        status = gpr(['calibrate', shipped, '--output', str(Path(tmp) / 'calibrated.yaml'), '--no-progress',
                      '--plot', str(OUT / 'calibration_residuals.png')])
    if status != 0:
        raise SystemExit(f'gpr calibrate exited with status {status}')


if __name__ == '__main__':
    main()
