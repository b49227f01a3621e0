"""Regenerate the figure of docs/architecture.md: ``python docs/img/architecture_figures.py`` (from the repo root).

The package's subpackages in their layers (``test/test_layout.py``'s ``LAYERS``, the one list of them) and the
imports between them, read from the source as that test reads them (every import statement, those inside functions
included, not those under ``if TYPE_CHECKING:``): an arrow from the importer to what it imports, as wide as the
number of module pairs it stands for. Every arrow points down or stays in its layer; none closes a loop.
"""
import math
import sys
from collections import Counter
from pathlib import Path

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / 'test'))
from test_layout import LAYERS, import_graph  # noqa: E402 - the layers' one source

OUT = Path(__file__).resolve().parent
#: The bottom layer, imported from everywhere: its arrows are left out (counted in the title).
BOTTOM = ('errors', 'callbacks')
#: A layer of one subpackage sits this far left or right of the middle, in turn, so that arrows do not overlap.
ZIGZAG = (-0.12, 0.12)


def part(module: str) -> str:
    """The subpackage (or top module) a module belongs to."""
    name = module.split('.')[1] if '.' in module else '__init__'
    return 'top' if name in ('__init__', '__main__') else name


def layers_figure() -> None:
    graph = import_graph()
    sizes = Counter(part(m) for m in graph)
    every = Counter((part(m), part(t)) for m, ts in graph.items() for t in ts if part(m) != part(t))
    edges = Counter({e: c for e, c in every.items() if e[1] not in BOTTOM})
    rows = [tuple('top' if n in ('__init__', '__main__') else n for n in names) for names in LAYERS]
    rows[-1] = ('top',)
    place = {}
    for y, names in enumerate(rows):
        for i, n in enumerate(names):
            place[n] = ((i + 1) / (len(names) + 1) + (ZIGZAG[y % 2] if len(names) == 1 else 0.0), y)
    fig, ax = plt.subplots(figsize=(9.0, 9.5), dpi=100)
    for (a, b), count in sorted(edges.items(), key=lambda e: e[1]):
        (xa, ya), (xb, yb) = place[a], place[b]
        same = ya == yb
        ax.annotate('', xy=(xb, yb + (0.0 if same else 0.22)), xytext=(xa, ya - (0.0 if same else 0.22)),
                    arrowprops=dict(arrowstyle='-|>', color='#1f77b4' if not same else '#d95f02',
                                    lw=0.4 + 0.9 * math.log(count), alpha=0.45, shrinkA=14, shrinkB=14,
                                    connectionstyle='arc3,rad=0.12' if not same else 'arc3,rad=0.35'))
    for n, (x, y) in place.items():
        label = 'package top\n(__init__, __main__)' if n == 'top' else f'{n}\n{sizes[n]} modules'
        if sizes[n] == 1 and n != 'top':
            label = f'{n}\n(one module)'
        ax.text(x, y, label, ha='center', va='center', fontsize=9,
                bbox=dict(boxstyle='round,pad=0.4', facecolor='#f2f2f2', edgecolor='#444444'))
    for y in range(len(rows)):
        ax.text(-0.02, y, f'layer {y + 1}', ha='right', va='center', fontsize=8, color='#666666')
        ax.axhline(y - 0.5, color='#dddddd', lw=0.6, zorder=0)
    ax.set_xlim(-0.12, 1.02)
    ax.set_ylim(-0.6, len(rows) - 0.4)
    ax.axis('off')
    total, bottom = sum(every.values()), sum(every.values()) - sum(edges.values())
    within = ' orange: within a layer;' if any(place[a][1] == place[b][1] for a, b in edges) else ''
    ax.set_title(f'gpr_kinematics: {len(graph)} modules in {len(rows)} layers; {total} module pairs import across '
                 f'subpackages, all downwards\n(arrow width: module pairs;{within} the {bottom} into '
                 f'{" and ".join(BOTTOM)}, from every layer, not drawn)', fontsize=10)
    fig.tight_layout()
    fig.savefig(OUT / 'architecture_layers.png')
    plt.close(fig)


if __name__ == '__main__':
    layers_figure()
