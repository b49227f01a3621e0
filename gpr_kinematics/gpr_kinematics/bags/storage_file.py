"""What a bag's storage file holds once read (MCAP or SQLite3): :class:`StorageFile`, the file as its readers
describe it, and :class:`Contents`, its messages by topic beside it."""
from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class StorageFile:
    """One storage file as read: its SHA-256, messages per topic, log-time span, and the CRCs it carried."""

    name: str
    size: int
    sha256: str
    counts: dict[str, int]
    types: dict[str, str]
    digests: dict[str, str]
    start: int | None
    end: int | None
    chunks: int = 0
    chunks_with_crc: int = 0
    data_crc: bool = False
    summary_crc: bool = False
    #: Per topic, the message definition the file embeds: (encoding, text) (MCAP schemas; SQLite3's
    #: ``message_definitions`` table where it has one).
    schemas: dict[str, tuple[str, str]] = field(default_factory=dict)
    #: Per topic, the serialization format of its messages as the file says (MCAP: the channel's message encoding).
    formats: dict[str, str] = field(default_factory=dict)
    #: Per topic, the ``offered_qos_profiles`` YAML the file stores (MCAP: the channel's metadata; SQLite3: the
    #: ``topics`` table's column, where it holds a profile).
    qos: dict[str, str] = field(default_factory=dict)
    #: SQLite3: the rows of the database's own ``metadata`` table (rosbag2's sqlite3 plugin stores the bag's metadata
    #: there as YAML): (row id, ``metadata_version``, text), in row order.
    embedded: tuple[tuple[int, object, str], ...] = ()
    #: MCAP: the ROS distribution each ``rosbag2`` metadata record states, with where (its ``ROS_DISTRO``, or
    #: ``ros_distro`` in its ``serialized_metadata``; None: that YAML unreadable, the reason in ``where``).
    distros: tuple[tuple[str, str | None], ...] = ()

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())


@dataclass
class Contents:
    """Messages of one storage file by topic (file order), and what the file says about itself."""

    file: StorageFile
    times: dict[str, list[int]]
    data: dict[str, list[bytes]]
    #: The uncompressed bytes of MCAP chunks, this file's and the bag's files' before it.
    inflated: int = 0
    #: The messages, this file's and the bag's files' before it (:data:`~.mcap_file.MAX_MESSAGES` bounds them).
    messages: int = 0
