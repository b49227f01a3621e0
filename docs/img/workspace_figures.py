"""Regenerate the figures of docs/workspace.md: ``python docs/img/workspace_figures.py`` (from the repo root)."""
from pathlib import Path

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt
import numpy as np
from gpr_kinematics.workspace import approximate
from gpr_kinematics.workspace.loader import load_workspace_model
from matplotlib.collections import PolyCollection

OUT = Path(__file__).resolve().parent


def draw(ax, res, i, j, sx=1.0, sy=1.0, section=None):
    """Projection on the (i, j) plane; with ``section=(k, value)`` only the boxes that contain x_k = value."""
    for arr, colour in ((res.boundary, '#f4a582'), (res.inner, '#2166ac')):
        if section is not None:
            k, value = section
            arr = arr[(arr[:, k, 0] <= value) & (value <= arr[:, k, 1])]
        r = np.unique(np.stack([arr[:, i, 0] * sx, arr[:, i, 1] * sx, arr[:, j, 0] * sy, arr[:, j, 1] * sy],
                               axis=1), axis=0)
        verts = np.stack([r[:, [0, 2]], r[:, [1, 2]], r[:, [1, 3]], r[:, [0, 3]]], axis=1)
        ax.add_collection(PolyCollection(verts, facecolors=colour, edgecolors='none'))
    ax.autoscale()


def tripod():
    model = load_workspace_model('tripod_3rps.yaml')
    res = approximate(model, 0.002)
    fig, ax = plt.subplots(figsize=(4.6, 4.0), dpi=100)
    draw(ax, res, 0, 1, 1e3, np.degrees(1.0))
    ax.set_xlabel('z [mm]')
    ax.set_ylabel('psi [deg]')
    ax.set_title('3-RPS tripod, projection on z-psi, delta = 2 mm\ninner (blue), boundary (orange)', fontsize=9)
    fig.tight_layout()
    fig.savefig(OUT / 'workspace_tripod_z_psi.png')
    plt.close(fig)


def gpr():
    model = load_workspace_model('gpr.yaml')
    model.box[1:] = [[-0.15, 0.15], [-0.15, 0.15]]
    res = approximate(model, 0.001)
    fig, ax = plt.subplots(figsize=(4.6, 4.0), dpi=100)
    draw(ax, res, 1, 2, np.degrees(1.0), np.degrees(1.0))
    az = np.linspace(0, 2 * np.pi, 721)
    lo, hi = np.zeros_like(az), np.full_like(az, 0.3)
    for _ in range(50):   # exact tilt limit of the budget, by bisection per azimuth
        mid = 0.5 * (lo + hi)
        g = model.evaluate(np.stack([np.full_like(az, 0.25), mid * np.cos(az), mid * np.sin(az)], axis=1))
        bad = np.abs(g[:, 3:]).max(axis=1) > model.budget
        hi, lo = np.where(bad, mid, hi), np.where(bad, lo, mid)
    ax.plot(np.degrees(lo * np.cos(az)), np.degrees(lo * np.sin(az)), 'k-', lw=0.8, label='exact, z = 0.25 m')
    ax.set_aspect('equal')
    ax.set_xlabel('tilt_x [deg]')
    ax.set_ylabel('tilt_y [deg]')
    ax.legend(loc='upper right', fontsize=7)
    ax.set_title('GPR tilts within the 0.5 mm budget (radial model)\nall heights, delta = 1 mm', fontsize=9)
    fig.tight_layout()
    fig.savefig(OUT / 'workspace_gpr_tilt.png')
    plt.close(fig)


def upu3():
    fig, axes = plt.subplots(2, 4, figsize=(10, 4.6), dpi=90, sharex=True, sharey=True)
    for row, (key, values) in enumerate((('b', (0.17, 0.2, 0.25, 0.3)), ('limb_max', (0.24, 0.27, 0.3, 0.33)))):
        for ax, v in zip(axes[row], values, strict=True):
            model = load_workspace_model('upu3.yaml', {key: v})
            model.box = np.array([[-0.4, 0.4], [-0.4, 0.4], [0.0, 0.4]])
            res = approximate(model, 0.005)
            draw(ax, res, 0, 2, 1e3, 1e3, section=(1, 0.0))
            ax.set_title(f'{key} = {v * 1e3:.0f} mm', fontsize=9)
            ax.set_aspect('equal')
    for ax in axes[:, 0]:
        ax.set_ylabel('z [mm]')
    for ax in axes[1]:
        ax.set_xlabel('x [mm]')
    fig.suptitle('3-UPU workspace, section y = 0 (delta = 5 mm): base size (top), limb limit (bottom)',
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(OUT / 'workspace_upu3_study.png')
    plt.close(fig)


def dextar_6d():
    """DexTAR in its 6-D form at delta = 6 mm, with the closed-form boundary (the circles of both annuli)."""
    res = approximate(load_workspace_model('dextar_6d.yaml'), 0.006)
    fig, ax = plt.subplots(figsize=(5.0, 4.4), dpi=100)
    draw(ax, res, 0, 1, 1e3, 1e3)
    t = np.linspace(0, 2 * np.pi, 400)
    for cx in (100.0, -100.0):
        ax.plot(cx + 400 * np.cos(t), 400 * np.sin(t), 'k-', lw=0.6)
    ax.plot([100, -100], [0, 0], 'k+', ms=8, label='pivots (arms fold: singular)')
    ax.set(xlim=(-520, 520), ylim=(-520, 520), xlabel='x [mm]', ylabel='y [mm]', aspect='equal')
    ax.legend(loc='lower center', fontsize=7)
    ax.set_title('DexTAR from its 6-D closure equations, delta = 6 mm\ninner (blue), boundary (orange), '
                 'exact boundary (black)', fontsize=9)
    fig.tight_layout()
    fig.savefig(OUT / 'workspace_dextar_6d.png')
    plt.close(fig)


def joint():
    """The joint working area's three projections (the paper's Fig. 17: xz, yz, xy) at delta = 6 mm."""
    res = approximate(load_workspace_model('joint_working_area.yaml'), 0.006)
    fig, axes = plt.subplots(1, 3, figsize=(12, 4.2), dpi=90)
    for ax, (i, j) in zip(axes, ((0, 2), (1, 2), (0, 1)), strict=True):
        draw(ax, res, i, j, 1e3, 1e3)
        ax.set_aspect('equal')
        ax.set_xlabel(f'{res.variables[i]} [mm]')
        ax.set_ylabel(f'{res.variables[j]} [mm]')
    fig.suptitle('Joint working area of the tripod over the planar 3-RRR: tool point in the planar platform frame, '
                 'delta = 6 mm; inner (blue), boundary (orange)', fontsize=10)
    fig.tight_layout()
    fig.savefig(OUT / 'workspace_joint_projections.png')
    plt.close(fig)


if __name__ == '__main__':
    tripod()
    gpr()
    upu3()
    dextar_6d()
    joint()
