"""Regenerate the figure of docs/core.md (the centre shift of the compliant model):
``python docs/img/core_figures.py`` from the repository root (needs the ``plot`` extra, matplotlib)."""
import math
from pathlib import Path

import numpy as np
from gpr_kinematics.core import inverse_batch
from gpr_kinematics.core.config import load_config

OUT = Path(__file__).resolve().parent


def centre_shift(kappa: float, tilts: np.ndarray, height: float = 0.5) -> np.ndarray:
    """Centre shift along x [m] for tilts about the x axis (inverse kinematics at ``height``), compliant model."""
    cfg = load_config(overrides={'model': 'compliant', 'kappa': float(kappa)})
    return inverse_batch(np.full(tilts.shape, height), tilts, 0.0, config=cfg).achieved.centre_shift[:, 0]


def main() -> None:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    cfg = load_config()
    R = cfg.radius
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), dpi=100)
    kappas = np.logspace(-3, 3, 61)
    for deg in (0.5, 1.0, 1.5, 2.0):
        alpha = math.radians(deg)
        shift = np.array([centre_shift(k, np.array([alpha]))[0] for k in kappas])
        left.semilogx(kappas, shift * 1e6, lw=2.5, alpha=0.6, label=f'tilt {deg:g} deg')
        law = R * alpha ** 2 / 4 * (kappas - 1) / (kappas + 1)
        left.semilogx(kappas, law * 1e6, ':', color='k', lw=0.9)
    radial = inverse_batch(0.5, cfg.tilt_limit, 0.0, model='radial').achieved.centre_shift[0, 0]
    left.axhline(radial * 1e6, color='0.5', lw=0.8, ls='--')
    left.text(1.5e-3, radial * 1e6 + 1.0, 'radial model, 2 deg', color='0.4', fontsize=8)
    left.set_xlabel('kappa = k_t / k_r')
    left.set_ylabel('centre shift along x [um]')
    left.set_title('Centre shift against the joints\' stiffness ratio\n(black dotted: R alpha^2/4 (kappa-1)/(kappa+1))',
                   fontsize=10)
    left.legend(fontsize=8)
    tilts = np.linspace(-cfg.tilt_limit, cfg.tilt_limit, 81)
    for kappa in (1e-3, 0.1, 1.0, 10.0, 1e3):
        right.plot(np.degrees(tilts), centre_shift(kappa, tilts) * 1e6, label=f'kappa {kappa:g}')
    right.set_xlabel('tilt about the x axis [deg]')
    right.set_ylabel('centre shift along x [um]')
    right.set_title('Centre shift against the tilt, 0.5 m', fontsize=10)
    right.legend(fontsize=8)
    for ax in (left, right):
        ax.grid(True, lw=0.3)
    fig.tight_layout()
    fig.savefig(OUT / 'core_centre_shift_compliant.png')
    plt.close(fig)


if __name__ == '__main__':
    main()
