"""The calibration's distribution points (``calibration.distributions``) are scipy.stats's to the last bit, and the
commands that use them no longer import scipy.stats (0.2-0.5 s of every ``gpr calibrate`` and ``gpr accuracy``)."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
from gpr_kinematics.calibration import distributions as d
from scipy import stats


def test_each_point_is_scipy_stats_to_the_last_bit():
    rng = np.random.default_rng(7)
    ps = np.concatenate([[1e-300, 1e-12, 5e-7, 5e-4, 0.001, 0.25, 0.5, 0.75, 0.999], rng.uniform(0, 1, 40)])
    dofs = np.concatenate([[1, 2, 3, 7.5, 90, 229, 1e4], rng.uniform(0.5, 300, 12)])
    xs = np.concatenate([[-40.0, -8.5, -1.0, -1e-9, 0.0, 1e-9, 0.5, 1.0, 3.2, 8.5, 38.0], rng.normal(0, 3, 200)])
    for x in xs:
        assert d.normal_pdf(x) == stats.norm.pdf(x) and d.normal_sf(x) == stats.norm.sf(x), x
    for p in ps:
        assert d.normal_isf(p) == stats.norm.isf(p), p
        for dof in dofs:
            assert d.chi2_ppf(p, dof) == stats.chi2.ppf(p, dof), (p, dof)
            assert d.t_isf(p, dof) == stats.t.isf(p, dof), (p, dof)


def test_the_calibration_and_its_commands_do_not_import_scipy_stats():
    """The modules ``gpr calibrate``, ``gpr calibrate-robot`` and ``gpr accuracy`` run (their gates, the arms'
    mixture points, the accuracy budget) import scipy.special, not scipy.stats."""
    modules = ', '.join(f'gpr_kinematics.{m}' for m in (
        'calibration.quality', 'calibration.identification', 'calibration.plausibility', 'calibration.arm_gpr',
        'calibration.chi2_mixture', 'calibration.budget', 'cli.calibrate', 'cli.calibrate_robot', 'cli.accuracy'))
    code = f'import sys, {modules}; print("scipy.special" in sys.modules, "scipy.stats" in sys.modules)'
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and out.stdout == 'True False\n', (out.stdout, out.stderr)
