"""Rows of measurements that repeat another: one measurement twice (a copied row or file), which counts as twice the
data (:func:`check_repeats`, the identification's check; it knows the standard deviations)."""
from __future__ import annotations

import math

import numpy as np

from ..errors import InputError
from .measurements import Measurements

#: Two rows whose rods and measurement agree to within this fraction of the standard deviation in every coordinate
#: (poses, points) are one measurement twice (:func:`repeated_rows`): two measurements agree that closely in each of
#: their 6 (3) noisy coordinates with probability t / sqrt(pi), in all below 1e-9 a pair (poses 0.056, points 0.0018).
REPEAT_TOLERANCE = {'pose': math.sqrt(math.pi) * 1e-9 ** (1 / 6), 'point': math.sqrt(math.pi) * 1e-9 ** (1 / 3)}


def repeated_rows(meas: Measurements, sigma_position: float, sigma_angle: float) -> list[tuple[int, int]]:
    """The rows of ``meas`` that repeat an earlier row, as ``(row, earlier row)`` in file order: the rods, the
    measured position and orientation all within :data:`REPEAT_TOLERANCE` of ``sigma_position`` [m] (the rods and
    the position) and ``sigma_angle`` [rad] (the angle between the orientations) of each other (a file copied into
    itself, rounded or not, counts twice: standard errors too small by ``sqrt 2``). ``O(N log N)`` (a k-d tree)."""
    from scipy.spatial import cKDTree

    n = len(meas)
    if n < 2:
        return []
    parts = [meas.q / sigma_position, meas.position / sigma_position]
    if meas.quaternion is not None:
        sign = np.where(meas.quaternion[:, 3:] < 0.0, -1.0, 1.0)   # q and -q are one orientation
        parts.append(2.0 * sign * meas.quaternion / sigma_angle)     # 2 |dq| is the angle between them
    X = np.hstack(parts) / REPEAT_TOLERANCE['point' if meas.quaternion is None else 'pose']
    X = X - X.mean(axis=0)
    dist, idx = cKDTree(X).query(X, k=2, p=np.inf, distance_upper_bound=1.0)
    found: dict[int, int] = {}
    for i in np.flatnonzero(np.isfinite(dist[:, 1])):
        j = int(idx[i, 1]) if int(idx[i, 1]) != i else int(idx[i, 0])
        a, b = min(int(i), j), max(int(i), j)
        found.setdefault(b, a)
    return sorted(found.items())


def check_repeats(meas: Measurements, sigma_position: float, sigma_angle: float) -> None:
    """Refuse rows that repeat another (:func:`repeated_rows`), naming the first ones.

    Raises:
        InputError: the file, the lines of the first repeated rows and of the rows they repeat, and what to do.
    """
    pairs = repeated_rows(meas, sigma_position, sigma_angle)
    if not pairs:
        return
    names = meas.row_names     # files merged (an arm's): a line number alone names no row
    b, a = pairs[0]
    listed = ', '.join(f'{names[i]} repeats {names[j]}' for i, j in pairs[1:4])
    others = f' ({listed}{", ..." if len(pairs) > 4 else ""})' if listed else ''
    angle = f' and {sigma_angle:.3g} rad' if meas.quaternion is not None else ''
    source = f'{meas.source}:' if meas.files else meas.source
    raise InputError(f'{source} {names[b]} repeats {names[a]}: the same rod lengths and measurement to within '
                     f'{REPEAT_TOLERANCE["pose" if angle else "point"]:.2g} of the standard deviation '
                     f'({sigma_position:.3g} m{angle}); {len(pairs)} '
                     f'such row(s){others}: a copied row or file counts as twice the data (standard errors too small '
                     'by sqrt 2); each measurement once. Separate measurements differ by their noise: if these are, '
                     'their noise is far below the standard deviation given (sigma columns, --sigma-position, '
                     '--sigma-angle)')
