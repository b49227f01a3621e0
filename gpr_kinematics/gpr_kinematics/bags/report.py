"""The verification report folder: ``verify.json``, ``verify.txt`` and PNG plots of the paper's figures 5-11.

Bratovanov & Sotirov §VI plot, against the sample of the singular-tilt sweep and zoomed in around the
singular configurations: Fig. 5 the rod lengths ``q``; for the polar model (``l``, ``phi``) Fig. 6 the
linear and Fig. 7 the angular virtual joints and Fig. 8 the side lengths ``L``; for the offset model
(``dr``, ``dphi``) Fig. 9, 10 and 11 the same. The bag carries the virtual joints of the model it was
recorded with (plotted from the messages); the other figures are computed from the bag's ``q`` with the
core (``forward_batch`` with that model), so every figure 5-11 exists for any bag. Each figure has the whole
stream on top and a zoom of +-``ZOOM`` samples around the first singular crossings below (dotted lines mark
the crossings). ``centre_shift_vs_tilt.png`` plots the horizontal centre shift against the tilt.
Units on the axes: mm and degrees (plots only; the data stay SI).
"""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..core import forward_batch
from ..core.config import GprConfig, measured_points
from ..core.virtual_joints import EDGE_NAMES
from ..errors import FileError, GprError
from ..inputs.files import atomic_output, output_folder, remove_output, writable_folder, write_text
from .errors import BagError
from .results import VerifyResult, format_table

if TYPE_CHECKING:
    from matplotlib.figure import Figure

ZOOM = 12
ZOOM_CROSSINGS = 3
#: A stream of at most this many samples is drawn with a marker at each.
MARKED_SAMPLES = 50
#: Every figure a report may draw (:func:`report_figures`): those the report of another bag drew in the same folder
#: and this one does not are removed (a model's own joints, every figure of a bag without states).
FIGURES = ('fig05_rod_lengths.png', 'fig08_side_lengths.png', 'fig06_polar_linear_virtual_joints.png',
           'fig07_polar_angular_virtual_joints.png', 'fig09_offset_linear_virtual_joints.png',
           'fig10_offset_angular_virtual_joints.png', 'compliant_virtual_joints.png', 'radial_virtual_joints.png',
           'centre_shift_vs_tilt.png')


def _plt() -> Any:
    """matplotlib's pyplot with the Agg backend; :class:`BagError` when matplotlib is not installed."""
    try:
        import matplotlib
    except ImportError:
        raise BagError('--report needs matplotlib for its plots, which is not installed') from None
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    return plt


def check_report_folder(folder: str | Path) -> Path:
    """Refuse a report folder that cannot be written before any work is done (nothing is created here): an
    existing path must be a writable folder, a new path must have a writable folder as its nearest existing
    ancestor. (Each file is checked again when written: :func:`gpr_kinematics.inputs.files.atomic_output`.)

    Raises:
        BagError: naming the path, what it is, and what is allowed.
    """
    out = Path(folder)
    allowed = 'allowed: a folder (created if missing) in a writable place'
    if str(folder) == '':
        raise BagError(f'--report is empty; {allowed}')
    if out.exists():
        if not out.is_dir():
            raise BagError(f'--report {out}: exists and is not a folder; {allowed}')
        if not os.access(out, os.W_OK | os.X_OK):
            raise BagError(f'--report {out}: the folder is not writable; {allowed}')
        return out
    try:
        writable_folder(out, '--report')
    except FileError as exc:  # its message names what is allowed
        raise BagError(str(exc)) from None
    return out


def _figure(title: str, sample: NDArray[np.int64], curves: NDArray[np.float64], labels: list[str], ylabel: str,
            crossings: NDArray[np.int64], reference: tuple[float, str] | None = None) -> Figure:
    """The stream on top and the zoom below, the legend beside the top (not on its curves), ``reference`` (a value
    and its label) a dashed line in both."""
    _plt()  # matplotlib there, the Agg backend chosen
    import matplotlib.pyplot as plt

    fig, (ax, az) = plt.subplots(2, 1, figsize=(10, 6.5), constrained_layout=True)
    for k, lab in enumerate(labels):   # a few samples marked (one sample's line drew nothing)
        ax.plot(sample, curves[:, k], lw=0.8, label=lab, marker='.' if len(sample) <= MARKED_SAMPLES else None)
    ax.set_title(title)
    ax.set_xlabel('sample')
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    sel = crossings[:ZOOM_CROSSINGS]
    if sel.size:
        lo, hi = max(0, int(sel[0]) - ZOOM), min(len(sample), int(sel[-1]) + ZOOM + 1)
        for k, lab in enumerate(labels):
            az.plot(sample[lo:hi], curves[lo:hi, k], '.-', lw=0.8, ms=3, label=lab)
        for c in sel:
            az.axvline(sample[c], color='k', ls=':', lw=0.8)
            ax.axvline(sample[c], color='k', ls=':', lw=0.3)
        az.set_title(f'zoom: samples {sample[lo]}..{sample[hi - 1]} around singular crossings (dotted)')
    else:
        az.text(0.5, 0.5, 'no singular crossing in this bag', ha='center', va='center', transform=az.transAxes)
    if reference is not None:
        for a in (ax, az):
            a.axhline(reference[0], color='k', ls='--', lw=0.8, label=reference[1])
    ax.legend(loc='upper left', bbox_to_anchor=(1.005, 1.0), fontsize=8)
    az.set_xlabel('sample')
    az.set_ylabel(ylabel)
    az.grid(alpha=0.3)
    return fig


def write_report(result: VerifyResult, folder: str | Path) -> list[Path]:
    """Write the report into ``folder`` (created; see :func:`check_report_folder`); returns the files written.

    Raises:
        BagError: the folder or a file cannot be written (named, with the reason).
    """
    out = check_report_folder(folder)
    try:
        return _write(result, out)
    except OSError as exc:
        raise BagError(f'--report {out}: cannot create or write {exc.filename or out}: {exc.strerror or exc}'
                       ) from None


def _save(fig: Figure, path: Path) -> Path:
    """Write the figure as PNG through the package's checked, atomic writer (an existing FIFO, device or link at
    ``path`` is refused: it would block the write, be overwritten or write elsewhere)."""
    try:
        with atomic_output(path, 'report', binary=True) as fh:
            fig.savefig(fh, format='png', dpi=90)
    finally:
        _plt().close(fig)
    return path


def _write(result: VerifyResult, out: Path) -> list[Path]:
    output_folder(out)
    written = [write_text(out / 'verify.json', json.dumps(result.to_dict(), indent=1, allow_nan=False) + '\n',
                          'report'),
               write_text(out / 'verify.txt', format_table(result) + '\n', 'report')]
    figures = report_figures(result)
    try:
        for name, fig in figures:
            written.append(_save(fig, out / name))
    finally:  # a write refused: the figures not written are closed too
        for _, fig in figures:
            _plt().close(fig)
    for name in sorted(set(FIGURES) - {name for name, _ in figures}):
        remove_output(out / name)   # an earlier report's figure of another bag: it stood beside this one's files
    return written


def report_figures(result: VerifyResult) -> list[tuple[str, Figure]]:
    """The report's figures (file name, matplotlib Figure), in the order written; none for a bag without states.
    Each title names the bag; lengths in mm, angles in deg, the centre shift in um."""
    s = result.series
    if s is None or s.q.shape[0] == 0:
        return []
    bag = Path(result.path).name
    x, cr = s.sample, s.crossings
    figures = [('fig05_rod_lengths.png', _figure(f'Fig. 5: rod lengths q (generalized coordinates), bag {bag}', x,
                                                 s.q * 1e3, ['q1', 'q2', 'q3'], 'q [mm]', cr)),
               ('fig08_side_lengths.png', _figure(f'Fig. 8 / Fig. 11: side lengths L = F(X), bag {bag}', x,
                                                  s.side_lengths * 1e3, list(EDGE_NAMES), 'L [mm]', cr))]
    finite = np.all(np.isfinite(s.q), axis=1)
    cfg = GprConfig.from_mapping(result.config, source='the verified geometry')
    # R is l at a singular configuration of the drawing's machine only (a measured one's joints stand elsewhere)
    radius = (cfg.radius * 1e3, f'R = {cfg.radius * 1e3:.3f} mm\n(l at a singular\nconfiguration)') \
        if not measured_points(cfg) else None
    for model, figs in (('polar', ('06', '07')), ('offset', ('09', '10'))):
        if s.model == model and s.virtual_joints.shape[1] == 6:
            X, source = s.virtual_joints, 'recorded'
        else:
            X = np.full((len(x), 6), np.nan)
            source = f'computed from the recorded q of a {s.model} bag'
            try:
                X[finite] = forward_batch(s.q[finite], cfg, model, check_limits=False).virtual_joints
            except GprError as exc:  # q far outside the workspace (a failed check already): an empty figure
                source = f'not computable from the recorded q: {type(exc).__name__}'
        names = ['l1', 'l2', 'l3'] if model == 'polar' else ['dr1', 'dr2', 'dr3']
        anames = ['phi1', 'phi2', 'phi3'] if model == 'polar' else ['dphi1', 'dphi2', 'dphi3']
        figures.append((f'fig{figs[0]}_{model}_linear_virtual_joints.png',
                        _figure(f'Fig. {int(figs[0])}: {model} model, linear virtual joints ({source}), bag {bag}', x,
                                X[:, :3] * 1e3, names, f'{names[0][:-1]} [mm]', cr,
                                radius if model == 'polar' else None)))
        figures.append((f'fig{figs[1]}_{model}_angular_virtual_joints.png',
                        _figure(f'Fig. {int(figs[1])}: {model} model, angular virtual joints ({source}), bag {bag}',
                                x, np.degrees(X[:, 3:]), anames, f'{anames[0][:-1]} [deg]', cr)))
    if s.model == 'compliant' and s.virtual_joints.shape[1] == 6:   # the physical model's: radial, tangential
        figures.append(('compliant_virtual_joints.png',
                        _figure(f'compliant model: dr1..3 (radial), dt1..3 (tangential) (recorded), bag {bag}', x,
                                s.virtual_joints * 1e3, ['dr1', 'dr2', 'dr3', 'dt1', 'dt2', 'dt3'], 'dr, dt [mm]', cr)))
    if s.model == 'radial' and s.virtual_joints.shape[1] == 3:
        figures.append(('radial_virtual_joints.png',
                        _figure(f"radial model (authors' earlier [11]): l1, l2, l3 (recorded), bag {bag}", x,
                                s.virtual_joints * 1e3, ['l1', 'l2', 'l3'], 'l [mm]', cr, radius)))
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 5), constrained_layout=True)
    tilt = np.degrees(s.tilt)
    shift = np.linalg.norm(s.centre_shift[:, :2], axis=1) * 1e6
    ax.plot(tilt, shift, '.', ms=3, label='|centre shift| in the base plane')
    ax.plot(tilt, np.abs(s.centre_shift[:, 2]) * 1e6, '.', ms=2, alpha=0.5, label='|z shift|')
    if np.isfinite(shift).any():
        k = int(np.nanargmax(shift))
        ax.plot([tilt[k]], [shift[k]], 'o', mfc='none', mec='k', ms=10,
                label=f'largest {shift[k]:.1f} um at tilt {tilt[k]:.2f} deg (sample {x[k]})')
    ax.set_xlabel('tilt [deg]')
    ax.set_ylabel('centre shift vs naive model [um]')
    ax.set_title(f'centre shift against tilt ({s.model} model), bag {bag}')
    ax.grid(alpha=0.3)
    ax.legend(loc='upper left', bbox_to_anchor=(1.005, 1.0), fontsize=8)   # beside: it hid the largest's circle
    figures.append(('centre_shift_vs_tilt.png', fig))
    return figures
