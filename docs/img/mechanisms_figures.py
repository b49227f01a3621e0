"""Regenerate the figures of docs/mechanisms.md: ``python docs/img/mechanisms_figures.py`` (from the repo root).

The 3-UPU translational manipulator's dexterity (the inverse condition number of its homogenised Jacobian) against
the height on the centre line, as Fig. 6 of Aboulissane and El Bakkali draws it, and over the x-z plane; both are
``gpr dexterity`` commands of docs/mechanisms.md, with ``--plot``.
"""
from pathlib import Path

from gpr_kinematics.cli.main import main

OUT = Path(__file__).resolve().parent

if __name__ == '__main__':
    for args in (['upu3.yaml', '--plot', str(OUT / 'mechanisms_upu3_fig6.png')],
                 ['upu3.yaml', '--vary', 'x', '-0.05', '0.05', '41', '--vary2', 'z', '0.17', '0.26', '37', '--plot',
                  str(OUT / 'mechanisms_upu3_map.png')]):
        assert main(['dexterity', *args]) == 0
