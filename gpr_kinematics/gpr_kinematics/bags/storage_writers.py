"""Writers of one storage file of a bag segment: MCAP (with every CRC) or SQLite3.

MCAP segments are written with the ``mcap`` library: chunk CRCs, the data-section CRC and the summary CRC
are all computed (the ``rosbags`` MCAP writer leaves them 0); the channels carry ``offered_qos_profiles`` and
``topic_type_hash`` and the file a ``rosbag2`` metadata record, as rosbag2's own MCAP plugin writes them.
SQLite3 segments are written with the ``rosbags`` writer (the format has no checksums: the bag's SHA-256 of
each file covers it).
"""
from __future__ import annotations

import hashlib
from importlib.metadata import version
from pathlib import Path
from typing import IO, Any, Protocol, cast

import yaml
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.metadata import dump_qos_v9

from .fileio import sha256_file
from .metadata import BAG_VERSION
from .typestore import LATCHED_TOPICS

#: Uncompressed bytes of an MCAP chunk (rosbags and rosbag2 use about the same).
MCAP_CHUNK_BYTES = 1 << 20
ROS_DISTRO = 'jazzy'
_T0 = QosTime(0, 0)
#: What the trajectory node offers on a latched topic (published once at start): reliable, transient local.
LATCHED_QOS = Qos(QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL, _T0, _T0,
                  QosLiveliness.AUTOMATIC, _T0, False)


def offered_profiles(topic: str) -> list[Qos]:
    """The QoS profiles offered on ``topic``: the latched profile, or none (unknown)."""
    latched = any(topic.endswith(k) for k in LATCHED_TOPICS)   # at the root or in a namespace (/r1/gpr/geometry)
    return [LATCHED_QOS] if latched else []


def offered_qos(topic: str) -> list[dict[str, Any]]:
    """``offered_qos_profiles`` stored for ``topic`` (v9 form): :func:`offered_profiles`."""
    return [dict(q) for q in dump_qos_v9(offered_profiles(topic))]


class StorageWriter(Protocol):
    """One segment's storage file being written."""

    file: Path

    def write(self, topic: str, timestamp: int, data: bytes) -> None: ...

    def close(self) -> None: ...

    def abort(self) -> None: ...

    def sha256(self) -> str:
        """Hex SHA-256 of the closed file."""
        ...


class _HashingStream:
    """A binary file that hashes what is written to it (the SHA-256 of a segment without reading it again)."""

    def __init__(self, path: Path) -> None:
        self.file = path.open('xb')
        self.digest = hashlib.sha256()

    def write(self, data: bytes) -> int:
        self.digest.update(data)
        return self.file.write(data)

    def tell(self) -> int:
        return self.file.tell()

    def flush(self) -> None:
        self.file.flush()

    def close(self) -> None:
        self.file.close()


class McapStorage:
    """An MCAP segment written with the ``mcap`` library, every CRC computed (see the module docstring)."""

    def __init__(self, folder: Path, topics: dict[str, str], defs: dict[str, tuple[str, str]],
                 compression: str) -> None:
        from mcap.writer import CompressionType
        from mcap.writer import Writer as McapWriter

        folder.mkdir(parents=True)
        self.file = folder / f'{folder.name}.mcap'
        self.stream = _HashingStream(self.file)
        # The writer uses write, tell and flush only, which the hashing stream has.
        self.writer = McapWriter(cast(IO[bytes], self.stream), chunk_size=MCAP_CHUNK_BYTES,
                                 compression=CompressionType.ZSTD if compression == 'zstd' else CompressionType.NONE,
                                 enable_crcs=True, enable_data_crcs=True)
        self.writer.start(profile='ros2', library=f'gpr_kinematics, mcap {version("mcap")}')
        schemas: dict[str, int] = {}
        self.channels: dict[str, int] = {}
        for topic, msgtype in topics.items():
            msgdef, digest = defs[topic]
            if msgtype not in schemas:
                schemas[msgtype] = self.writer.register_schema(name=msgtype, encoding='ros2msg', data=msgdef.encode())
            self.channels[topic] = self.writer.register_channel(
                topic=topic, message_encoding='cdr', schema_id=schemas[msgtype],
                metadata={'offered_qos_profiles': yaml.safe_dump(offered_qos(topic)).rstrip('\n'),
                          'topic_type_hash': digest})
        self.sequence = 0

    def write(self, topic: str, timestamp: int, data: bytes) -> None:
        self.sequence += 1
        self.writer.add_message(self.channels[topic], log_time=timestamp, data=data, publish_time=timestamp,
                                sequence=self.sequence & 0xFFFFFFFF)

    def close(self) -> None:
        self.writer.add_metadata('rosbag2', {'ROS_DISTRO': ROS_DISTRO})
        self.writer.finish()
        self.stream.close()

    def abort(self) -> None:
        self.stream.close()

    def sha256(self) -> str:
        return self.stream.digest.hexdigest()


class Sqlite3Storage:
    """An SQLite3 segment written with the ``rosbags`` writer (bag format version 9)."""

    def __init__(self, folder: Path, topics: dict[str, str], defs: dict[str, tuple[str, str]]) -> None:
        self.writer = Writer(folder, version=BAG_VERSION, storage_plugin=StoragePlugin.SQLITE3)
        self.file = folder / f'{folder.name}.db3'
        self.writer.open()
        # the database's topics table carries the offered profiles too (rosbag2's sqlite3 plugin reads them there:
        # '[]' made a player offer its latched topics volatile while metadata.yaml said latched)
        self.connections = {topic: self.writer.add_connection(topic, msgtype, msgdef=defs[topic][0],
                                                              rihs01=defs[topic][1],
                                                              offered_qos_profiles=offered_profiles(topic))
                            for topic, msgtype in topics.items()}

    def write(self, topic: str, timestamp: int, data: bytes) -> None:
        self.writer.write(self.connections[topic], timestamp, data)

    def close(self) -> None:
        self.writer.close()

    def abort(self) -> None:
        self.writer.abort()

    def sha256(self) -> str:
        return sha256_file(self.file, 'segment')  # SQLite writes the file itself: read it once more
