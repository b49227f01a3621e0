"""Exceptions of the bag layer."""
from __future__ import annotations

from ..errors import GprError


class BagError(GprError):
    """A bag cannot be read or written: missing or bad ``metadata.yaml``, truncated or foreign storage file,
    output folder that exists or is not writable, unknown message type. The CLI maps it to exit status 2."""
