"""Comment lines for the calibration's text files (measurements, plans, calibrated geometry).

Reading and writing go through the package's one bounded reader and atomic writer, :mod:`gpr_kinematics.inputs.files`
(re-exported here for the calibration's modules).
"""
from __future__ import annotations

from ..inputs.files import read_text, write_text

__all__ = ['comment_lines', 'read_text', 'write_text']


def comment_lines(comments: tuple[str, ...] | list[str]) -> str:
    r"""``comments`` as ``# `` lines, control characters (a newline in a file name) replaced by spaces, so a
    comment can never end early and inject content into a YAML or CSV file.

    >>> comment_lines(['from a\nradius: 5.csv'])
    '# from a radius: 5.csv\n'
    """
    return ''.join('# ' + ''.join(ch if ch.isprintable() else ' ' for ch in c) + '\n' for c in comments)
