"""Tampered bags written by an independent MCAP writer: the public ``mcap`` library (not the package's recorder,
not ``rosbags``) writes every storage file of a bag folder again after an edit, with every CRC (chunks, the data
and the summary sections) computed anew, and ``metadata.yaml`` is recounted and re-signed (its file SHA-256 sums and
its own digest recomputed, as the recorder writes them): an editor who knows every checksum of the format. What is
left to catch the edit are ``gpr verify``'s checks of the content (issue 18).

Edits (:func:`tampered`): ``message(topic, index, raw) -> raw | None`` (None drops the message; the bytes are CDR),
``schema(name, text) -> text`` (the embedded message definitions), ``encoding(name, encoding) -> encoding`` (their
encodings), ``channel(topic, metadata) -> metadata`` (a channel's metadata: its type hash, its offered QoS),
``metadata(info)`` (the metadata's mapping, after it was recounted); ``twin`` (a topic: its messages on a channel of
the edited definition and metadata, an empty second channel with the originals).
"""
from __future__ import annotations

import hashlib
import shutil
import sqlite3
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from gpr_kinematics.bags.metadata import FILE_DIGEST_PREFIX, METADATA_DIGEST_KEY, render_metadata
from gpr_kinematics.bags.typestore import typestore
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

MessageEdit = Callable[[str, int, bytes], 'bytes | None']


def _rewrite_mcap(src: Path, dst: Path, message: MessageEdit | None, schema: Callable[[str, str], str] | None,
                  seen: dict[str, int], encoding: Callable[[str, str], str] | None = None,
                  channel: Callable[[str, dict[str, str]], dict[str, str]] | None = None,
                  twin: str | None = None,
                  records: Callable[[str, dict[str, str]], dict[str, str] | None] | None = None) -> None:
    with open(src, 'rb') as fh:
        reader = make_reader(fh)
        header = reader.get_header()
        summary = reader.get_summary()
        assert summary is not None
        metadata = list(reader.iter_metadata())
        with open(dst, 'wb') as out:
            writer = Writer(out, compression=CompressionType.ZSTD, enable_crcs=True, enable_data_crcs=True)
            writer.start(profile=header.profile, library='mcap-python (tamper test)')
            schema_ids = {}
            twin_schema, edit_channel = None, None
            if twin is not None:   # the edits go to the twin topic's message-carrying channel only (below)
                twin_schema, edit_channel, schema, encoding, channel = schema, channel, None, None, None
            for sid, s in sorted(summary.schemas.items()):
                text = s.data.decode()
                schema_ids[sid] = writer.register_schema(s.name,
                                                         encoding(s.name, s.encoding) if encoding else s.encoding,
                                                         (schema(s.name, text) if schema else text).encode())
            channel_ids = {cid: writer.register_channel(c.topic, c.message_encoding, schema_ids[c.schema_id],
                                                        channel(c.topic, dict(c.metadata)) if channel
                                                        else dict(c.metadata))
                           for cid, c in sorted(summary.channels.items()) if c.topic != twin}
            for cid, c in sorted(summary.channels.items()):
                if c.topic == twin:   # the messages on a channel of the edited definition and metadata, then an
                    s = summary.schemas[c.schema_id]   # empty twin channel with the originals, registered last
                    edited_id = writer.register_schema(s.name, s.encoding, twin_schema(s.name, s.data.decode()).encode()
                                                       if twin_schema else s.data)
                    channel_ids[cid] = writer.register_channel(c.topic, c.message_encoding, edited_id,
                                                               edit_channel(c.topic, dict(c.metadata)) if edit_channel
                                                               else dict(c.metadata))
                    writer.register_channel(c.topic, c.message_encoding, schema_ids[c.schema_id], dict(c.metadata))
            for _, channel, msg in reader.iter_messages(log_time_order=False):
                i = seen.get(channel.topic, 0)
                seen[channel.topic] = i + 1
                data = message(channel.topic, i, msg.data) if message else msg.data
                if data is not None:
                    writer.add_message(channel_ids[channel.id], msg.log_time, data, msg.publish_time, msg.sequence)
            for m in metadata:   # ``records``: each metadata record edited, or left out where it gives None
                kept = records(m.name, dict(m.metadata)) if records else dict(m.metadata)
                if kept is not None:
                    writer.add_metadata(m.name, kept)
            writer.finish()


def _counted(path: Path) -> tuple[list[int], dict[str, int]]:
    """The log times of a storage file's messages and their count per topic, read by the ``mcap`` library or by
    SQLite itself (the package's reader refuses some of the edits, which a re-signer need not mind)."""
    if path.suffix == '.mcap':
        with open(path, 'rb') as fh:
            rows = [(ch.topic, msg.log_time) for _, ch, msg in make_reader(fh).iter_messages(log_time_order=False)]
    else:
        con = sqlite3.connect(path)
        try:
            rows = con.execute('SELECT topics.name, messages.timestamp FROM messages LEFT JOIN topics ON topics.id = '
                               'messages.topic_id').fetchall()
        finally:
            con.close()
    per: dict[str, int] = {}
    for topic, _ in rows:
        per[topic] = per.get(topic, 0) + 1
    return [t for _, t in rows], per


def resign(folder: Path, edit: Callable[[dict[str, Any]], None] | None = None) -> None:
    """Recount ``metadata.yaml`` from the files (per file and per topic counts, times, totals), apply ``edit``, and
    recompute the files' SHA-256 and the metadata digest."""
    path = folder / 'metadata.yaml'
    info = yaml.safe_load(path.read_text())['rosbag2_bagfile_information']
    files = {name: _counted(folder / name) for name in info['relative_file_paths']}
    for entry in info['files']:
        times = files[entry['path']][0]
        entry['message_count'] = len(times)
        if times:
            entry['starting_time']['nanoseconds_since_epoch'] = min(times)
            entry['duration']['nanoseconds'] = max(times) - min(times)
    for t in info['topics_with_message_count']:
        t['message_count'] = sum(per.get(t['topic_metadata']['name'], 0) for _, per in files.values())
    info['message_count'] = sum(len(times) for times, _ in files.values())
    starts = [min(times) for times, _ in files.values() if times]
    ends = [max(times) for times, _ in files.values() if times]
    if starts:
        info['starting_time']['nanoseconds_since_epoch'] = min(starts)
        info['duration']['nanoseconds'] = max(ends) - min(starts)
    if edit is not None:
        edit(info)
    custom = {k: v for k, v in (info.get('custom_data') or {}).items() if k != METADATA_DIGEST_KEY}
    for name in files:
        custom[FILE_DIGEST_PREFIX + name] = hashlib.sha256((folder / name).read_bytes()).hexdigest()
    info['custom_data'] = custom
    path.write_bytes(render_metadata(info))


def tampered(src: Path, dst: Path, message: MessageEdit | None = None, schema: Callable[[str, str], str] | None = None,
             metadata: Callable[[dict[str, Any]], None] | None = None,
             encoding: Callable[[str, str], str] | None = None,
             channel: Callable[[str, dict[str, str]], dict[str, str]] | None = None, twin: str | None = None,
             records: Callable[[str, dict[str, str]], dict[str, str] | None] | None = None) -> Path:
    """A copy of the bag folder ``src`` at ``dst``, its MCAP files written again by the ``mcap`` library with the
    edits, its metadata recounted and re-signed (module docstring). ``twin``: a topic whose messages go to a channel
    of the ``schema`` and ``channel`` edits (no other channel is edited), followed by an empty second channel of
    that topic with the file's own definition and metadata."""
    shutil.copytree(src, dst)
    seen: dict[str, int] = {}
    for f in sorted(dst.glob('*.mcap')):
        _rewrite_mcap(src / f.name, f, message, schema, seen, encoding, channel, twin, records)
    resign(dst, metadata)
    return dst


def edited(msgtype: str, raw: bytes, change: Callable[[Any], Any]) -> bytes:
    """CDR bytes of the message ``raw`` after ``change(message)`` (which returns the new message)."""
    store = typestore()
    return bytes(store.serialize_cdr(change(store.deserialize_cdr(raw, msgtype)), msgtype))


def set_path(msg: Any, path: list[str | int], value: Any) -> Any:
    """A copy of the ``rosbags`` message ``msg`` with the field at ``path`` (names and sequence indices) set to
    ``value`` (numeric sequences are numpy arrays: copied, then the element set)."""
    import dataclasses

    head, rest = path[0], path[1:]
    if isinstance(head, int):
        if isinstance(msg, np.ndarray):
            out = msg.copy()
            out[head] = value
            return out
        items = list(msg)
        items[head] = set_path(items[head], rest, value) if rest else value
        return items
    inner = getattr(msg, head)
    return dataclasses.replace(msg, **{head: set_path(inner, rest, value) if rest else value})


def swapped_poses(name: str, text: str) -> str:
    """PlatformState's definition (``name`` its type) with ``pose`` and ``nominal_pose`` swapped: every message still
    decodes, each pose under the other's name (other types' ``text`` unchanged)."""
    if not name.endswith('PlatformState'):
        return text
    return (text.replace('geometry_msgs/Pose pose\n', 'TMP\n')
            .replace('geometry_msgs/Pose nominal_pose\n', 'geometry_msgs/Pose pose\n')
            .replace('TMP\n', 'geometry_msgs/Pose nominal_pose\n'))
