"""Holding back what C code writes to standard error while rclpy starts (rcl's own log line, rcutils' "error state
is being overwritten" block before an ``RCLError``), so that a refused start is one line."""
from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator


@contextlib.contextmanager
def stderr_held() -> Iterator[None]:
    """Hold back what C code writes to stderr (rcl's own log line before an RCLError) until the block ends; it
    is written out only when the block succeeds, so a failed init leaves one ``cannot start`` line. Without a stderr
    (a node started with ``2>&-``) there is nothing to hold."""
    try:
        saved = os.dup(2)
    except OSError:
        yield
        return
    with tempfile.TemporaryFile() as held:
        os.dup2(held.fileno(), 2)
        ok = False
        try:
            yield
            ok = True
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            if ok:
                held.seek(0)
                data = held.read()
                if data:
                    os.write(2, data)
