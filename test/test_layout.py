"""The package's layout is its architecture: a small public top, layers that import only downwards, no import loops.

The import graph is read from the source (every ``import`` and ``from ... import`` statement, those inside functions
included; only those under ``if TYPE_CHECKING:`` are left out, as they never run).
"""
from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

PACKAGE_DIR = Path(__file__).resolve().parents[1] / 'gpr_kinematics' / 'gpr_kinematics'
TOP = 'gpr_kinematics'
#: The layers from the bottom up; a module may import its own layer's modules and those of the layers below.
LAYERS: tuple[tuple[str, ...], ...] = (
    ('errors', 'callbacks'),
    ('inputs',),
    ('core',),
    ('robot', 'mechanisms'),
    ('workspace', 'calibration', 'safety'),
    ('bags',),
    ('ros',),
    ('nodes',),
    ('cli',),
    ('__init__', '__main__'),
)
MAX_TOP_MODULES = 8


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE_DIR.parent).with_suffix('').parts)
    if parts[-1] == '__init__':
        parts = parts[:-1]
    return '.'.join(parts)


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and 'TYPE_CHECKING' in ast.unparse(node.test):
            skip.update(id(n) for stmt in node.body for n in ast.walk(stmt))
    return skip


@functools.cache
def import_graph() -> dict[str, set[str]]:
    """Module -> the package's modules it imports (a name imported from a package that is one of its submodules
    counts as that submodule); read once per test run."""
    files = {_module_name(p): p for p in PACKAGE_DIR.rglob('*.py')}
    graph: dict[str, set[str]] = {}
    for module, path in files.items():
        tree = ast.parse(path.read_text(encoding='utf-8'))
        skip = _type_checking_nodes(tree)
        package = module if path.name == '__init__.py' else module.rpartition('.')[0]
        targets: set[str] = set()
        for node in ast.walk(tree):
            if id(node) in skip:
                continue
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split('.')[:len(package.split('.')) - node.level + 1]
                    target = '.'.join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ''
                for alias in node.names:
                    sub = f'{target}.{alias.name}'
                    targets.add(sub if sub in files else target)
            elif isinstance(node, ast.Import):
                targets.update(a.name for a in node.names)
        graph[module] = {t for t in targets if t in files and t != module}
    return graph


def _layer(module: str) -> int:
    part = module.split('.')[1] if '.' in module else '__init__'
    part = part.removesuffix('.py')
    for i, names in enumerate(LAYERS):
        if part in names:
            return i
    raise AssertionError(f'{module} is in no layer of LAYERS: add its subpackage to the layer it belongs to')


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_loops():
    assert _cycles(import_graph()) == []


def test_layers_import_only_downwards():
    upward = sorted(f'{a} -> {b}' for a, targets in import_graph().items() for b in targets if _layer(b) > _layer(a))
    assert upward == [], 'a lower layer imports a higher one (LAYERS): ' + '; '.join(upward)


def test_package_top_is_small():
    top = sorted(p.name for p in PACKAGE_DIR.glob('*.py'))
    assert len(top) <= MAX_TOP_MODULES, top


def test_cycle_finder_finds_a_loop():
    assert _cycles({'a': {'b'}, 'b': {'c'}, 'c': {'a'}, 'd': {'a'}}) == [['a', 'b', 'c']]


@pytest.mark.parametrize('module', ['gpr_kinematics.core.forward', 'gpr_kinematics.cli.main'])
def test_graph_sees_imports_inside_functions(module):
    graph = import_graph()
    assert graph[module], module


def test_progress_callback_type_has_one_home():
    """``StageProgress`` is defined in ``callbacks`` (layer 1) and imported from there, never sideways (it was in
    ``safety.check``, imported by ``calibration`` and ``cli``)."""
    homes, sources = [], set()
    for path in PACKAGE_DIR.rglob('*.py'):
        module = _module_name(path)
        for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
            if isinstance(node, ast.Assign) and any(getattr(t, 'id', '') == 'StageProgress' for t in node.targets):
                homes.append(module)
            elif isinstance(node, ast.ImportFrom) and any(a.name == 'StageProgress' for a in node.names):
                sources.add((node.module or '').rpartition('.')[2])
    assert homes == [f'{TOP}.callbacks']
    assert sources == {'callbacks'}
