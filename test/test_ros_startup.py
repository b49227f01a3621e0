"""Start-up and run-time errors of every executable (issue 10 and 14): a malformed ``--ros-args``, params file or
parameter value, bad recorder/replay topics, a corrupt bag or a FIFO given to replay_node, and a full disk under
the recorder each end the process with the documented status and exactly one ``cannot start:`` / ``stopped:``
line, never a traceback."""
from __future__ import annotations

import math
import os
import re
import resource
import shutil
import signal
import tempfile
import time
from pathlib import Path

import pytest
from gpr_kinematics.ros.process import NodeProcess
from gpr_kinematics.ros.specs import NODES, node_specs
from ros_support import assert_one_error_line, start, wait_for_log

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / 'bags' / 'reference_sweep'
#: Parameters every executable needs to start at all (replay_node needs a bag).
NEEDS = {'replay_node': ['-p', f'bag:={REFERENCE}'], 'recorder_node': []}


def _run(exe: str, *args: str, timeout: float = 60.0):
    proc = start(exe, *NEEDS.get(exe, []), *args)
    try:
        status = proc.wait(timeout=timeout)
    finally:
        proc.stop()
    return status, proc.output()


def _files(tmp_path: Path) -> dict[str, Path]:
    nonros = tmp_path / 'geometry_style.yaml'
    nonros.write_text('radius: 0.1\nstroke_max: 0.6\n')            # a geometry file, not a ROS params file
    broken = tmp_path / 'broken.yaml'
    broken.write_text('kinematics_node: {ros__parameters: [\n')
    one = tmp_path / 'one_kappa.yaml'
    one.write_text('kinematics_node:\n  ros__parameters:\n    kappa: 1000.0\n')   # the geometry file's form
    return {'nonros': nonros, 'broken': broken, 'missing': tmp_path / 'missing.yaml', 'one': one}


MALFORMED = {
    'param-without-value': (['-p', 'rate'], r'cannot start: malformed ROS arguments: .*-p rate'),
    'bad-remap': (['-r', 'no rule'], r'cannot start: malformed ROS arguments: .*remap'),
    'non-ros-params-file': (['--params-file', '{nonros}'], r'cannot start: .*ros__parameters.*gpr_params\.yaml'),
    'broken-params-file': (['--params-file', '{broken}'], r'cannot start: .*params file'),
    'missing-params-file': (['--params-file', '{missing}'], r'cannot start: .*params file'),
    # rclpy takes no integer for a double: the docs' "characteristic_length 0 (= radius)" typed as 0
    'integer-for-double': (['-p', 'characteristic_length:=0'], r"cannot start: .*'0' of type 'INTEGER', expecting type "
                                                               r"'DOUBLE'.*; allowed: a floating-point value from 0\.0 "
                                                               r'to 100\.0 \(write 0\.0\)$'),
    # nor one number for an array (a geometry file's kappa: 1000.0): said so without 'allowed:' before
    'number-for-array': (['-p', 'kappa:=1000.0'], r"cannot start: .*'1000\.0' of type 'DOUBLE', expecting type "
                                                  r"'DOUBLE_ARRAY': kappa; allowed: a list of 3 numbers, one per "
                                                  r'rod \(\[1000\.0, 1000\.0, 1000\.0\] for 1000\.0 at each\)$'),
    'number-for-array-file': (['--params-file', '{one}'], r"expecting type 'DOUBLE_ARRAY': kappa; allowed: a list "
                                                          r'of 3 numbers, one per rod \(\[1000\.0, 1000\.0, 1000\.0\] '
                                                          r'for 1000\.0 at each\)$'),
    'integer-for-array': (['-p', 'rod_offsets:=0'], r"expecting type 'DOUBLE_ARRAY': rod_offsets; allowed: a list of "
                                                    r'3 numbers, one per rod \(\[0\.0, 0\.0, 0\.0\] for 0\.0 at '
                                                    r'each\)$'),
    'integers-for-array': (['-p', 'rod_azimuths:=[0, 2, 4]'], r"'INTEGER_ARRAY', expecting type 'DOUBLE_ARRAY': "
                                                              r'rod_azimuths; allowed: a list of 3 numbers, one per '
                                                              r'rod \(\[0\.0, 2\.0, 4\.0\]: floating-point\)$'),
    'text-for-list': (['-p', 'topics:=/joint_states'], r"expecting type 'STRING_ARRAY': topics; allowed: a list of "
                                                       r"texts, e\.g\. \['/joint_states'\]$"),
}


# Every executable with two of the cases, one executable with all of them: the start-up path (runtime.run) is one.
MALFORMED_CASES = [(exe, case) for exe in NODES for case in ('param-without-value', 'non-ros-params-file')] + \
    [('kinematics_node', case) for case in MALFORMED if case not in ('param-without-value', 'non-ros-params-file',
                                                                      'text-for-list')] + \
    [('recorder_node', 'text-for-list')]


@pytest.mark.parametrize('exe,case', MALFORMED_CASES)
def test_malformed_ros_args_exit_2_one_line(exe, case, tmp_path):
    args, words = MALFORMED[case]
    files = _files(tmp_path)
    status, out = _run(exe, '--ros-args', *[a.format(**files) for a in args])
    assert_one_error_line(out, status, 2, words)
    assert '[rcl]' not in out          # rcl's own "Failed to parse global arguments" line is not shown


#: rclpy's logging without a folder for its files: HOME unset, no ROS_LOG_DIR or ROS_HOME.
NO_LOG_FOLDER = r'ROS logging cannot start \(failed to initialize logging: .*\): .*allowed: ROS_LOG_DIR'


@pytest.mark.parametrize('exe', ['kinematics_node', 'recorder_node'])
def test_a_node_without_a_log_folder_names_it_not_its_arguments(exe):
    """HOME unset (a service started by an init system): the nodes said "malformed ROS arguments" where none were
    given, with no way out; now the log folder and ROS_LOG_DIR."""
    env = {k: v for k, v in os.environ.items() if k not in ('HOME', 'ROS_LOG_DIR', 'ROS_HOME')}
    proc = NodeProcess(exe, NEEDS.get(exe, []), env=env)
    try:
        status = proc.wait(timeout=60)
    finally:
        proc.stop()
    line = assert_one_error_line(proc.output(), status, 2, 'cannot start: ' + NO_LOG_FOLDER)
    assert 'malformed' not in line


def test_a_domain_id_that_is_no_number_is_named_not_the_arguments():
    """ROS_DOMAIN_ID=abc read "malformed ROS arguments" where none were given; now the variable and what it takes."""
    proc = NodeProcess('kinematics_node', [], env=dict(os.environ, ROS_DOMAIN_ID='abc'))
    try:
        status = proc.wait(timeout=60)
    finally:
        proc.stop()
    line = assert_one_error_line(proc.output(), status, 2, r'cannot start: ROS_DOMAIN_ID is not an integral number; '
                                 r'allowed: ROS_DOMAIN_ID unset or an integer from 0 to 232$')
    assert 'malformed' not in line


def test_send_without_a_log_folder_is_one_line_not_a_traceback():
    """``gpr program send`` with HOME unset ended in an RCLError traceback behind rcutils' "error state is being
    overwritten" block; now one line, status 2."""
    import subprocess
    import sys
    env = {k: v for k, v in os.environ.items() if k not in ('HOME', 'ROS_LOG_DIR', 'ROS_HOME')}
    proc = subprocess.run([sys.executable, '-m', 'gpr_kinematics', 'program', 'send', 'example_robot_program.yaml',
                           '--timeout', '1'], env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count('\n') == 1 and 'Traceback' not in proc.stderr, proc.stderr
    assert re.match(r'gpr program send: error: cannot start a ROS client: ' + NO_LOG_FOLDER, proc.stderr), proc.stderr


def _params_file(path: Path, body: str) -> Path:
    path.write_text('kinematics_node:\n  ros__parameters:\n' + body)
    return path


def test_a_params_file_beyond_the_bounds_is_refused_before_rcl_reads_it(tmp_path):
    """A list of 80,000 values (320 kB): rcl's parser took 5 to 20 s over it (quadratic), deaf to SIGTERM; the
    package's bounded reader refuses it at once, naming the file and the limit (every node: one start-up path)."""
    big = _params_file(tmp_path / 'long.yaml', '    kappa: [' + ','.join(['1.0'] * 80_000) + ']\n')
    began = time.monotonic()
    status, out = _run('state_publisher_node', '--ros-args', '--params-file', str(big), timeout=30)
    assert_one_error_line(out, status, 2, r"cannot start: params file '.*long\.yaml': line 3: more than 20000 YAML "
                          r'values; allowed: at most 20000')
    assert time.monotonic() - began < 10


def test_a_params_file_with_a_key_twice_is_refused_naming_both_lines(tmp_path):
    """``radius: 0.09`` then ``radius: 0.1``: rcl kept the last without a word; every package YAML refuses it."""
    twice = _params_file(tmp_path / 'twice.yaml', '    radius: 0.09\n    radius: 0.1\n')
    status, out = _run('kinematics_node', '--ros-args', '--params-file', str(twice), timeout=30)
    assert_one_error_line(out, status, 2, r"cannot start: params file '.*twice\.yaml': line 4: duplicate key "
                          r"'radius' \(first on line 3\)")


@pytest.mark.parametrize('exe, prefix, longest', [('state_publisher_node', 'r1//', 'gpr_platform_nominal'),
                                                  ('trajectory_node', 'x' * 92 + '/', 'gpr_base')])
def test_a_prefix_whose_frames_break_the_frame_name_rule_is_refused(exe, prefix, longest):
    """r1// (r1//gpr_base) and 93 characters before gpr_base (101) started and named frames tf2 and the frame
    parameters refuse: the node's check counts the frames it names (the state publisher its URDF's links)."""
    status, out = _run(exe, '--ros-args', '-p', f'frame_prefix:={prefix}', timeout=30)
    assert_one_error_line(out, status, 2, r'cannot start: parameter frame_prefix = .* is invalid; allowed: empty, or '
                          r'letters, digits, _ and single / between parts, not starting with /, at most '
                          rf'{100 - len(longest)} characters \({longest}: ')


@pytest.mark.parametrize('exe, frame', [('state_publisher_node', 'world'), ('trajectory_node', 'world'),
                                        ('trajectory_node', 'arm1_wafer')])
def test_a_base_frame_named_like_another_frame_of_the_robot_is_refused(exe, frame):
    """trajectory_node started with base_frame:=world and labelled the platform's poses (gpr_base coordinates)
    world, beside wafer poses in the real world frame, 0.9 m apart in the example robot; the state publisher refused
    it: both do now, with one line."""
    status, out = _run(exe, '--ros-args', '-p', f'base_frame:={frame}', timeout=30)
    assert_one_error_line(out, status, 2, rf"cannot start: base_frame = '{frame}' is the name of another frame of "
                          r'robot example_dual_arm \(its world, rods, arms, blades and wafers\); allowed: a frame of '
                          'its own')


@pytest.mark.parametrize('exe', ['kinematics_node', 'trajectory_node'])
def test_a_prefix_too_long_for_the_robots_world_frame_is_refused(exe, tmp_path):
    """Both nodes name ``prefix + the robot's world frame`` (a service's world_frame, a stream's header): with a world
    frame of 64 characters a prefix of 37 made frames of 101 (92 and 79 characters made 156 and 144) and both started;
    the prefix is counted against the robot's world frame too."""
    source = Path(__file__).resolve().parents[1] / 'gpr_kinematics' / 'config' / 'robots' / 'example_robot.yaml'
    world = 'w' * 64
    robot = tmp_path / 'robot.yaml'
    robot.write_text(source.read_text().replace('\n  frame: world', f'\n  frame: {world}', 1))
    status, out = _run(exe, '--ros-args', '-p', f'robot_file:={robot}', '-p', 'frame_prefix:=' + 'p' * 36 + '/',
                       timeout=30)
    assert_one_error_line(out, status, 2, r'cannot start: parameter frame_prefix = .* is invalid; allowed: .*at most '
                          rf'36 characters \({world}: ')


@pytest.mark.parametrize('exe', list(NODES))
def test_parameter_of_the_wrong_type_exit_2_one_line(exe):
    spec = next(s for s in node_specs(exe) if s.kind in ('double', 'integer') and s.name != 'rate')
    status, out = _run(exe, '--ros-args', '-p', f'{spec.name}:=not_a_number')
    assert_one_error_line(out, status, 2, 'cannot start', spec.name)


def test_a_node_without_stderr_starts_serves_and_refuses_as_with_one():
    """A node started with stderr closed (``2>&-``; a process manager may start it so): it serves and leaves with 0,
    and a bad parameter still exits 2 (holding rcl's start-up line back duplicated fd 2: an OSError, status 1)."""
    from gpr_kinematics.nodes.client import GprClient
    from gpr_kinematics.ros.process import NodeProcess

    def no_stderr():
        os.close(2)

    bad = NodeProcess('kinematics_node', ['-p', 'tolerance:=not_a_number'], preexec=no_stderr)
    try:
        assert bad.wait(timeout=60) == 2
    finally:
        bad.stop()
    node = NodeProcess('kinematics_node', ['-r', '__ns:=/no_stderr'], preexec=no_stderr)
    try:
        with GprClient('no_stderr_client', namespace='/no_stderr') as c:
            ok = c.forward_kinematics([0.5, 0.498, 0.502])
            refused = c.forward_kinematics([0.5, 0.498, 9.0])
        assert ok.success and abs(ok.pose.position.z - 0.5) < 0.01
        assert not refused.success and 'stroke' in refused.message
        assert node.alive()
    finally:
        assert node.stop() == 0


def test_a_node_process_takes_its_log_folder_with_it(tmp_path):
    """Every NodeProcess without a log folder made one in /tmp and left it (329 after a day's test runs): the folder
    is its own now, read while it lives and removed with it; ``echo`` makes none, a given folder is kept."""
    import gc

    from gpr_kinematics.ros.process import NodeProcess

    bad = NodeProcess('kinematics_node', ['-p', 'radius:=21.0'])
    assert bad.wait(timeout=60) == 2
    folder = bad.log_dir
    assert folder is not None and folder.parent == Path(tempfile.gettempdir()) and 'radius' in bad.output()
    del bad
    gc.collect()
    assert not folder.exists()
    given = NodeProcess('kinematics_node', ['-p', 'radius:=21.0'], log_dir=tmp_path / 'logs')
    assert given.wait(timeout=60) == 2
    del given
    gc.collect()
    assert 'radius' in (tmp_path / 'logs' / 'kinematics_node.err').read_text()
    echo = NodeProcess('kinematics_node', ['-p', 'radius:=21.0'], echo=True)
    try:
        assert echo.log_dir is None and echo.output() == ''
    finally:
        echo.stop()


@pytest.mark.parametrize('exe', list(NODES))
def test_parameter_out_of_range_exit_2_one_line(exe):
    spec = next(s for s in node_specs(exe) if s.limits is not None and s.kind == 'double')
    status, out = _run(exe, '--ros-args', '-p', f'{spec.name}:={spec.limits[1] * 2 + 1.0!r}')
    assert_one_error_line(out, status, 2, 'cannot start', spec.name)


BAD_NAMES = [("['gpr/bad name']", r"'gpr/bad name' is not a valid topic name"),
             ("['gpr//double']", 'not a valid topic name'),
             ("['2gpr/starts_with_digit']", 'not a valid topic name')]
# replay_node documents topics:=[''] as "all topics" (its default): an empty name is refused by the recorder only.
TOPIC_CASES = [(exe, value, words) for exe in ('recorder_node', 'replay_node') for value, words in BAD_NAMES] + \
    [('recorder_node', "['']", 'empty topic name'),
     # a topic twice, with two types: the last one was recorded without a word
     ('recorder_node', "['/a:std_msgs/msg/String','/a:std_msgs/msg/Int32']", '/a is given twice')]


@pytest.mark.parametrize('exe,value,words', TOPIC_CASES)
def test_bad_topic_names_exit_2_one_line(exe, value, words, tmp_path):
    args = ['-p', f'output:={tmp_path / "bag"}'] if exe == 'recorder_node' else []
    status, out = _run(exe, '--ros-args', *args, '-p', f'topics:={value}')
    assert_one_error_line(out, status, 2, 'cannot start', 'topics', words)
    assert not (tmp_path / 'bag').exists()


@pytest.mark.parametrize('value', ['-1.0', '3601.0', '.nan'])
def test_a_recorder_drain_timeout_out_of_its_range_exit_2_one_line(value, tmp_path):
    """The drain at a stop was 5 s, fixed; ``drain_timeout`` bounds it from 0 to an hour, named when refused."""
    status, out = _run('recorder_node', '--ros-args', '-p', f'output:={tmp_path / "bag"}', '-p',
                       f'drain_timeout:={value}', timeout=30)
    assert_one_error_line(out, status, 2, 'cannot start', r'drain_timeout out of range Min: 0\.0, Max: 3600\.0')
    assert not (tmp_path / 'bag').exists()


def test_recorder_empty_topic_list_exit_2(tmp_path):
    status, out = _run('recorder_node', '--ros-args', '-p', f'output:={tmp_path / "bag"}', '-p', 'topics:=[]')
    assert_one_error_line(out, status, 2, 'cannot start: topics is empty')
    assert not (tmp_path / 'bag').exists()


@pytest.mark.parametrize('value', ['[]', "['']"])
def test_replay_empty_topic_list_means_all_topics(value):
    from gpr_kinematics.bags.reader import read_bag

    ref = read_bag(REFERENCE)
    status, out = _run('replay_node', '--ros-args', '-p', 'rate:=100.0', '-p', f'topics:={value}')
    assert status == 0 and 'Traceback' not in out, out
    assert f'replaying {ref.message_count} messages of {len(ref.topics)} topic(s)' in out


NAME_TOO_LONG = r'name too long; allowed: a path whose names have at most 255 bytes each, 4096 in all$'


@pytest.mark.parametrize('exe,parameter', [('replay_node', 'bag'), ('recorder_node', 'output')])
def test_a_bag_path_too_long_exit_2_one_line_naming_it_cut(exe, parameter, tmp_path):
    """A name of 300 characters: ``Path.exists`` raised ENAMETOOLONG, ``cannot start: internal error: OSError``
    (status 1) with the path whole."""
    long = str(tmp_path / ('x' * 300))
    status, out = _run(exe, '--ros-args', '-p', f'{parameter}:={long}', '-p', 'storage:=sqlite3'
                       if exe == 'recorder_node' else 'rate:=1.0')
    line = assert_one_error_line(out, status, 2, rf'cannot start: .*\.\.\. \({len(long)} characters\): {NAME_TOO_LONG}')
    assert long not in line


def _corrupt_copy(tmp_path: Path, how: str) -> Path:
    bag = tmp_path / 'bag'
    shutil.copytree(REFERENCE, bag)
    mcap = next(bag.glob('*.mcap'))
    data = bytearray(mcap.read_bytes())
    if how == 'truncated':
        mcap.write_bytes(bytes(data[:len(data) // 2]))
    elif how == 'garbage':
        mcap.write_bytes(b'\x00' * len(data))
    elif how == 'fifo-file':
        mcap.unlink()
        os.mkfifo(mcap)
    elif how == 'metadata-not-yaml':
        (bag / 'metadata.yaml').write_text('rosbag2_bagfile_information: [\n')
    elif how == 'storage-name-too-long':   # a storage file of 300 characters listed (no digests to match)
        meta = bag / 'metadata.yaml'
        lines = [line for line in meta.read_text().splitlines(keepends=True) if 'sha256' not in line]
        meta.write_text(''.join(lines).replace(mcap.name, 'x' * 300 + '.mcap'))
    return bag


@pytest.mark.parametrize('how', ['truncated', 'garbage', 'fifo-file', 'metadata-not-yaml', 'storage-name-too-long'])
def test_replay_corrupt_bag_exit_2_one_line(how, tmp_path):
    bag = _corrupt_copy(tmp_path, how)
    status, out = _run('replay_node', '--ros-args', '-p', f'bag:={bag}', timeout=60)
    assert_one_error_line(out, status, 2, 'cannot start', str(bag))


def test_replay_fifo_as_the_bag_exit_2(tmp_path):
    fifo = tmp_path / 'stream.mcap'
    os.mkfifo(fifo)
    t0 = time.monotonic()
    status, out = _run('replay_node', '--ros-args', '-p', f'bag:={fifo}', timeout=60)
    # The bag reader's one check (bags.fileio.require_regular): the kind of file named, never opened.
    assert_one_error_line(out, status, 2, 'cannot start', 'is a FIFO; allowed: a regular file')
    assert time.monotonic() - t0 < 30


def _file_size_limit(limit: int):
    def apply() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return apply


@pytest.mark.slow
def test_recorder_full_disk_stops_with_one_line_and_keeps_the_closed_segments(tmp_path):
    """A file size limit (RLIMIT_FSIZE, as a full disk: writes fail with EFBIG) under an SQLite3 recording: small
    segments close fine while a slow stream runs; a fast stream then overfills a segment. The recorder ends with
    status 1 and one ``stopped:`` line under its own name; the segments closed before stay a readable bag."""
    from gpr_kinematics.bags.reader import read_bag
    from gpr_kinematics.ros.process import NodeProcess

    bag = tmp_path / 'bag'
    env = {**os.environ, 'FASTDDS_BUILTIN_TRANSPORTS': 'UDPv4'}    # no shared-memory files under the limit
    rec = NodeProcess('recorder_node', ['-p', f'output:={bag}', '-p', 'storage:=sqlite3', '-p', 'flush_interval:=0.2',
                                        '-p', 'topics:=[gpr/platform_state, gpr/markers]', '-r', '__node:=rec_full'],
                      env=env, preexec=_file_size_limit(100_000))
    slow = fast = None
    try:
        wait_for_log(rec, 'recording 2 topic')
        slow = start('trajectory_node', rate=40.0, wait_for_subscribers=1, wait_all_topics=False,
                     azimuth_step=math.radians(120.0), tilt_step=math.radians(0.5))
        assert slow.wait(timeout=60) == 0, slow.output()
        fast = start('trajectory_node', rate=2000.0, wait_for_subscribers=1, wait_all_topics=False, passes=20)
        status = rec.wait(timeout=60)
    finally:
        for p in (rec, slow, fast):
            if p is not None:
                p.stop(signal.SIGINT)
    out = rec.output()
    # by the node's name as remapped (it was logged as [recorder_node])
    assert_one_error_line(out, status, 1, r'\[rec_full\]: stopped: BagError: cannot write the bag .*disk full')
    assert 'segment(s) closed before the error' in out
    b = read_bag(bag)
    states = b.topic('/gpr/platform_state')
    assert states is not None and len(states) >= 3 * 9     # at least the slow stream (3 rows of 9 samples)


def test_a_start_refused_half_way_destroys_its_node_before_rclpy_shuts_down(monkeypatch):
    """``runtime.run`` with a node whose ``__init__`` raises after rclpy's node exists (as the recorder's refusal of
    an output it cannot create): status 2, and the half-built node destroyed while rclpy still runs (it was left
    to the garbage collector after the shutdown, where rclpy and Fast DDS hang now and then)."""
    import rclpy
    from gpr_kinematics.errors import GprError
    from gpr_kinematics.nodes import runtime
    from std_msgs.msg import String

    events = []

    class Refused(runtime.GprNode):
        NODE_NAME = 'refused_half_way'

        def __init__(self) -> None:
            super().__init__()
            self.create_publisher(String, 'x', 1)
            raise GprError('refused after the node was built')

        def destroy_node(self) -> None:
            events.append(('destroyed', rclpy.ok()))
            super().destroy_node()

    shutdown = rclpy.try_shutdown
    monkeypatch.setattr(rclpy, 'try_shutdown', lambda *a, **k: (events.append(('shutdown', rclpy.ok())),
                                                                 shutdown(*a, **k)))
    assert runtime.run(Refused, []) == 2
    assert events == [('destroyed', True), ('shutdown', True)]


def test_a_refused_process_leaves_even_when_rclpy_shutdown_hangs():
    """A refused start in its own process (the console script's ``run(..., args=None)``) leaves with its status and
    its one line, also when rclpy's shutdown hangs (as Fast DDS did now and then: a refused recorder stayed 60 s in
    a CI run): the watchdog ends it after ``REFUSED_EXIT_WAIT``; without a hang it leaves at once, skipping the
    interpreter's finalisation."""
    import subprocess
    import sys
    import time

    script = (
        'import sys, time, rclpy\n'
        'from gpr_kinematics.errors import GprError\n'
        'from gpr_kinematics.nodes import runtime\n'
        'runtime.REFUSED_EXIT_WAIT = 1.0\n'
        'class Refused(runtime.GprNode):\n'
        '    NODE_NAME = "refused_hanging"\n'
        '    def __init__(self):\n'
        '        super().__init__()\n'
        '        raise GprError("refused on purpose")\n'
        'if sys.argv[1] == "hang":\n'
        '    rclpy.try_shutdown = lambda *a, **k: time.sleep(3600)\n'
        'sys.argv = sys.argv[:1]\n'
        'runtime.run(Refused)\n'
        'print("returned: the process should have left")\n')
    for mode, most in (('hang', 20.0), ('plain', 20.0)):
        t0 = time.monotonic()
        res = subprocess.run([sys.executable, '-c', script, mode], capture_output=True, text=True, timeout=60)
        took = time.monotonic() - t0
        assert res.returncode == 2, (mode, res.returncode, res.stdout, res.stderr)
        assert 'cannot start: refused on purpose' in res.stdout + res.stderr, (mode, res.stderr)
        assert 'returned' not in res.stdout and took < most, (mode, took)
