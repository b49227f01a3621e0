"""The code is lint clean (ruff, ruff.toml), type checks (mypy, mypy.ini), and the docs stand alone."""
import re
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _tool(name):
    exe = Path(sys.executable).with_name(name)
    return [str(exe)] if exe.exists() else [shutil.which(name) or name]


def test_ruff_clean():
    paths = [p for p in ('gpr_kinematics', 'test', 'benchmarks', 'docs', 'setup.py') if (ROOT / p).exists()]
    res = subprocess.run(_tool('ruff') + ['check', *paths], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stdout + res.stderr


def test_mypy_clean():
    res = subprocess.run(_tool('mypy') + ['--config-file', 'mypy.ini'], cwd=ROOT, capture_output=True, text=True,
                         timeout=600)
    assert res.returncode == 0, res.stdout + res.stderr


#: Files of other parts of the project that still point at notes outside the repository: owner clears this.
NOT_YET_SELF_CONTAINED: set[str] = set()
#: A design note and the papers' text files that are not part of the repository (a user has neither).
OUTSIDE = re.compile(r'design\.md|seeds[/]|(gpr-virtual-joints|workspace-nonuniform-covering|stewart-accuracy-alwan'
                     r'|3upu-aboulissane|gsp-inverse-jacobians)[\w-]*\.txt|\b\d{3}_[0-9a-f]{16}\.txt')


def test_docs_cite_papers_not_files_outside_the_repository():
    files = subprocess.run(['git', 'ls-files', '-co', '--exclude-standard'], cwd=ROOT, capture_output=True,
                           text=True, timeout=60).stdout.split()
    found = []
    for name in files:
        path = ROOT / name
        if name in NOT_YET_SELF_CONTAINED or path.suffix not in ('.py', '.md', '.yaml', '.txt', '.cfg', '.ini'):
            continue
        if path.is_file() and OUTSIDE.search(path.read_text(encoding='utf-8', errors='replace')):
            found.append(name)
    assert found == [], f'cite the paper (docs/references.md), not a file outside the repository: {found}'


#: Modules of other parts of the project still over the size limit: owner clears this.
NOT_YET_SMALL: set[str] = set()
MAX_MODULE_LINES = 450


def test_modules_stay_small():
    big = [str(p.relative_to(ROOT)) for p in sorted((ROOT / 'gpr_kinematics' / 'gpr_kinematics').rglob('*.py'))
           if len(p.read_text(encoding='utf-8').splitlines()) > MAX_MODULE_LINES
           and str(p.relative_to(ROOT)) not in NOT_YET_SMALL]
    assert big == [], f'split these modules (at most {MAX_MODULE_LINES} lines each): {big}'
