"""Helpers of the bag tests: the reference bag, small synthetic bags, re-signed (tampered) copies, running
``gpr verify`` in a subprocess under an address-space limit and a timeout."""
from __future__ import annotations

import hashlib
import json
import math
import resource
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import yaml
from gpr_kinematics.bags.metadata import FILE_DIGEST_PREFIX, METADATA_DIGEST_KEY
from gpr_kinematics.bags.reader import read_bag
from gpr_kinematics.bags.synthetic import sweep_messages
from gpr_kinematics.bags.typestore import typestore
from gpr_kinematics.bags.writer import SegmentedBagWriter

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / 'bags' / 'reference_sweep'
STATE = '/gpr/platform_state'
MARKERS = '/gpr/markers'
#: Address space of a ``gpr verify`` process in the corruption tests: verify needs ~400 MiB (numpy, scipy,
#: rosbags imported); an allocation from a corrupt length would need far more.
ADDRESS_SPACE = 768 << 20


def small_sweep(**kw: Any) -> list[tuple[str, int, bytes]]:
    """1 deg tilt steps, 60 deg azimuth steps: 6 rows x 5 tilts = 30 samples, every topic, the geometry first."""
    return sweep_messages(tilt_step=math.radians(1.0), azimuth_step=math.radians(60.0), **kw)


def messages_of(path: Path) -> list[tuple[str, int, bytes]]:
    """Every message of a bag as (topic, log time, bytes) in log-time order."""
    bag = read_bag(path)
    out = [(t.name, int(ts), raw) for t in bag.topics.values() for ts, raw in zip(t.log_time, t.raw, strict=True)]
    return sorted(out, key=lambda m: m[1])


def write_bag(dst: Path, messages: list[tuple[str, int, bytes]], types: dict[str, str], **kw: Any) -> Path:
    """A new bag (written, hashed and signed by the writer as a recording would be)."""
    with SegmentedBagWriter(dst, types, flush_interval=0, fsync=False, **kw) as w:
        for topic, t, raw in messages:
            w.write(topic, t, raw)
    return dst


def example_robot_bag(dst: Path) -> Path:
    """The example robot program streamed at 10 Hz as the node streams it, written and checked to verify."""
    from gpr_kinematics.bags.synthetic import robot_program_messages
    from gpr_kinematics.bags.typestore import GPR_TOPICS
    from gpr_kinematics.bags.verify import verify_bag
    from gpr_kinematics.inputs.resources import config_path
    from gpr_kinematics.robot import load_robot
    from gpr_kinematics.robot.program import load_program

    program = load_program(config_path('programs/example_robot_program.yaml'))
    bag = write_bag(dst, robot_program_messages(load_robot(), program, 10.0), dict(GPR_TOPICS))
    assert verify_bag(bag).passed
    return bag


def rewritten(src: Path, dst: Path, edit: Callable[[str, Any], Any], **kw: Any) -> Path:
    """A copy of ``src`` in which ``edit(topic, message)`` changed messages, written again through the writer:
    its checksums are valid, so only the content checks can find the change."""
    bag = read_bag(src)
    store = typestore()
    types = {name: t.msgtype for name, t in bag.topics.items()}
    out = []
    for topic, t, raw in messages_of(src):
        msg = store.deserialize_cdr(raw, types[topic])
        new = edit(topic, msg)
        if new is not None:
            out.append((topic, t, new if isinstance(new, bytes) else bytes(store.serialize_cdr(new, types[topic]))))
    return write_bag(dst, out, types, **kw)


def copy_bag(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    return dst


def resign_metadata(folder: Path, edit: Callable[[dict[str, Any]], None]) -> None:
    """Edit ``metadata.yaml``'s information and recompute its digest and file hashes as the writer would (an
    editor who knows the scheme): what is left to catch the edit are the checks of the content."""
    from gpr_kinematics.bags.metadata import render_metadata

    path = folder / 'metadata.yaml'
    info = yaml.safe_load(path.read_text())['rosbag2_bagfile_information']
    edit(info)
    custom = {k: v for k, v in (info.get('custom_data') or {}).items() if k != METADATA_DIGEST_KEY}
    for k in list(custom):
        if k.startswith(FILE_DIGEST_PREFIX) and (folder / k[len(FILE_DIGEST_PREFIX):]).is_file():
            custom[k] = hashlib.sha256((folder / k[len(FILE_DIGEST_PREFIX):]).read_bytes()).hexdigest()
    info['custom_data'] = custom
    path.write_bytes(render_metadata(info))


def _limit_address_space() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE, ADDRESS_SPACE))


_WORKER = r'''
import contextlib, io, json, sys, traceback
from gpr_kinematics.cli import main as cli
for line in sys.stdin:
    path = line.rstrip('\n')
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = cli.main(['verify', path])
        except BaseException:  # nothing may escape cli.main: the test fails on it
            status = 'raised: ' + traceback.format_exc()
    print(json.dumps({'path': path, 'status': status, 'out': out.getvalue()[-3000:], 'err': err.getvalue()}),
          flush=True)
'''


def verify_many(paths: list[Path], timeout: float) -> list[dict[str, Any]]:
    """``gpr verify`` of each path, in one worker process under :data:`ADDRESS_SPACE` (an allocation beyond it
    raises MemoryError, which nothing catches) and ``timeout`` seconds for all (a hang fails the test)."""
    proc = subprocess.run([sys.executable, '-c', _WORKER], input=''.join(f'{p}\n' for p in paths), text=True,
                          capture_output=True, timeout=timeout, preexec_fn=_limit_address_space)
    results = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith('{')]
    assert proc.returncode == 0 and len(results) == len(paths), (proc.returncode, proc.stderr[-3000:],
                                                                 len(results), len(paths))
    return results


def verify_process(path: Path, *args: str, timeout: float = 60) -> subprocess.CompletedProcess[str]:
    """``gpr verify PATH ARGS`` as its own process (the installed entry point's code path), limited as above."""
    return subprocess.run([sys.executable, '-m', 'gpr_kinematics.cli.main', 'verify', str(path), *args], text=True,
                          capture_output=True, timeout=timeout, preexec_fn=_limit_address_space)
