"""The code is lint clean (ruff, configured in ruff.toml)."""
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_ruff_clean():
    ruff = Path(sys.executable).with_name('ruff')
    cmd = [str(ruff)] if ruff.exists() else [shutil.which('ruff') or 'ruff']
    paths = [p for p in ('gpr_kinematics', 'test', 'benchmarks', 'setup.py') if (ROOT / p).exists()]
    res = subprocess.run(cmd + ['check', *paths], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stdout + res.stderr
