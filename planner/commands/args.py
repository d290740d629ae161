"""Command-line values: numbers, coordinates and MAVLink connection strings, checked once.

Each function here is an ``argparse`` ``type=``: it turns the text of one option into a
value or raises :class:`argparse.ArgumentTypeError` with what is wrong, and argparse puts
the option's name in front (``argument --lane-heading-deg: must be a finite number, got
'nan'``); :mod:`planner.cli` prints that as one line and exits 2. ``float("nan")``,
``float("inf")`` and ``"1e999"`` are never let through: every number is finite and in
the range its option states.
"""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Callable

#: Connection kinds pymavlink opens from a ``KIND:HOST:PORT`` string.
NETWORK_KINDS = ("udpin", "udpout", "udp", "udpbcast", "tcp", "tcpin")
#: The serial device forms accepted (a path under /dev, or a Windows COM port).
_SERIAL = re.compile(r"^(/dev/[\w./-]+|COM\d{1,3})(,(\d{3,7}))?$")
_LABEL = r"[A-Za-z0-9]([A-Za-z0-9-]{0,61}[A-Za-z0-9])?"
_HOST = re.compile(rf"^(\d{{1,3}}(\.\d{{1,3}}){{3}}|{_LABEL}(\.{_LABEL})*)$")
CONNECTION_FORMS = ("udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT "
                    "or a serial device (/dev/ttyACM0[,BAUD])")


def _finite(text: str) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return value


def number(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False,
           unit: str = "") -> Callable[[str], float]:
    """A finite float within ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``)."""
    suffix = f" {unit}" if unit else ""

    def parse(text: str) -> float:
        value = _finite(text)
        if lo is not None and (value <= lo if lo_open else value < lo):
            raise argparse.ArgumentTypeError(f"must be {'>' if lo_open else '>='} {lo:g}{suffix}, got {text}")
        if hi is not None and value > hi:
            raise argparse.ArgumentTypeError(f"must be <= {hi:g}{suffix}, got {text}")
        return value

    parse.__name__ = "number"
    return parse


def integer(lo: int | None = None, hi: int | None = None) -> Callable[[str], int]:
    """A whole number within ``[lo, hi]``."""

    def parse(text: str) -> int:
        try:
            value = int(text.strip())
        except (TypeError, ValueError):
            raise argparse.ArgumentTypeError(f"must be a whole number, got {text!r}") from None
        if lo is not None and value < lo:
            raise argparse.ArgumentTypeError(f"must be >= {lo}, got {value}")
        if hi is not None and value > hi:
            raise argparse.ArgumentTypeError(f"must be <= {hi}, got {value}")
        return value

    parse.__name__ = "integer"
    return parse


#: A finite number (any sign).
finite = number()
#: A finite number > 0.
positive = number(0.0, lo_open=True)
#: A finite number >= 0.
nonnegative = number(0.0)
#: A compass heading or angle in degrees, -360..360.
heading_deg = number(-360.0, 360.0, unit="deg")


def lat_lon(text: str) -> tuple[float, float]:
    """``LAT,LON`` in WGS84 degrees (latitude -90..90, longitude -180..180)."""
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"must be LAT,LON in degrees, got {text!r}")
    try:
        lat, lon = (float(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be LAT,LON in degrees, got {text!r}") from None
    if not (math.isfinite(lat) and -90.0 <= lat <= 90.0):
        raise argparse.ArgumentTypeError(f"latitude must be within -90..90 deg, got {text!r}")
    if not (math.isfinite(lon) and -180.0 <= lon <= 180.0):
        raise argparse.ArgumentTypeError(f"longitude must be within -180..180 deg, got {text!r}")
    return lat, lon


def connection_string(text: str) -> str:
    """A MAVLink connection pymavlink can open: ``KIND:HOST:PORT`` or a serial device.

    The check is of the form only (no name is looked up, nothing is opened).
    """
    value = text.strip()
    serial = _SERIAL.match(value)
    if serial:
        return value
    parts = value.split(":")
    if len(parts) != 3 or parts[0] not in NETWORK_KINDS:
        raise argparse.ArgumentTypeError(f"{text!r} is not a MAVLink connection; expected {CONNECTION_FORMS}")
    kind, host, port_text = parts
    if not _HOST.match(host):
        raise argparse.ArgumentTypeError(f"{text!r}: {host!r} is not a host name or IPv4 address")
    if host[0].isdigit() and host.replace(".", "").isdigit() and any(int(b) > 255 for b in host.split(".")):
        raise argparse.ArgumentTypeError(f"{text!r}: {host!r} is not an IPv4 address")
    if not port_text.isdigit() or not 1 <= int(port_text) <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r}: port must be 1..65535, got {port_text!r}")
    return f"{kind}:{host}:{int(port_text)}"
