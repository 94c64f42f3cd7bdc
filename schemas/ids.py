"""UUIDv7 generation (RFC 9562) for server-made and demo records.

Phones generate their own IDs; the gateway uses this only for rows it creates itself.
"""

from __future__ import annotations

import os
import time
import uuid


def uuid7() -> str:
    """A time-ordered UUIDv7 in canonical lower-case text form."""
    unix_ms = time.time_ns() // 1_000_000
    rand = int.from_bytes(os.urandom(10), "big")
    value = (unix_ms & ((1 << 48) - 1)) << 80
    value |= 0x7 << 76  # version
    value |= ((rand >> 62) & 0xFFF) << 64  # rand_a, 12 bits
    value |= 0b10 << 62  # RFC 4122 variant
    value |= rand & ((1 << 62) - 1)  # rand_b, 62 bits
    return str(uuid.UUID(int=value))
