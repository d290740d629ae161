"""MAVLink 2 message signing: keys and the per-connection signing state.

With a key configured every message we send is signed and every unsigned or badly signed
message we receive is rejected by the parser (it becomes BAD_DATA and is counted, never
dispatched). The signing timestamp is real time (10 us ticks since 2015-01-01) by the
protocol's definition, so it reads the wall clock, not the injected clock.
"""

from __future__ import annotations

import hashlib
import time
from typing import Any

from vehicle_link.errors import ConfigError
from vehicle_link.units import SIGNING_EPOCH_UNIX_S

SIGNING_KEY_LEN = 32


def key_from_passphrase(passphrase: str) -> bytes:
    """32-byte key as SHA-256 of a passphrase (MAVProxy's and QGroundControl's convention)."""
    if not passphrase:
        raise ConfigError("signing passphrase is empty")
    return hashlib.sha256(passphrase.encode("utf-8")).digest()


def key_from_hex(text: str) -> bytes:
    """32-byte key from 64 hexadecimal characters."""
    try:
        key = bytes.fromhex(text.strip())
    except ValueError:
        raise ConfigError("signing key must be 64 hexadecimal characters") from None
    return check_key(key)


def check_key(key: bytes) -> bytes:
    """Return ``key`` if it is 32 bytes, else raise ConfigError."""
    if not isinstance(key, bytes | bytearray) or len(key) != SIGNING_KEY_LEN:
        n = len(key) if isinstance(key, bytes | bytearray) else type(key).__name__
        raise ConfigError(f"signing key must be {SIGNING_KEY_LEN} bytes, got {n}")
    return bytes(key)


def signing_timestamp_now() -> int:
    """Current MAVLink signing timestamp: 10 microsecond units since 2015-01-01 UTC."""
    return int(max(0.0, time.time() - SIGNING_EPOCH_UNIX_S) * 100_000)


def enable_signing(mav: Any, key: bytes, *, link_id: int = 0) -> None:
    """Sign everything ``mav`` sends and reject unsigned input (no unsigned exceptions).

    Parameters
    ----------
    mav : pymavlink ``MAVLink`` (v2)
        The protocol object of one connection.
    key : bytes
        32-byte secret key shared with the vehicle.
    link_id : int
        MAVLink 2 signing link id, 0..255.
    """
    if not 0 <= link_id <= 255:
        raise ConfigError(f"signing link_id must be 0..255, got {link_id}")
    mav.signing.secret_key = check_key(key)
    mav.signing.sign_outgoing = True
    mav.signing.allow_unsigned_callback = None
    mav.signing.link_id = link_id
    mav.signing.timestamp = signing_timestamp_now()
