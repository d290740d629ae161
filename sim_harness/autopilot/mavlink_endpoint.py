"""The vehicle's MAVLink socket: a UDP server (as BlueOS's UDP server endpoint) or TCP server.

Transports are non-blocking and polled once per simulator step. :class:`MavlinkPort`
frames and parses MAVLink 2 with pymavlink's ardupilotmega dialect and runs every packet,
both ways, through :class:`~sim_harness.faults.LinkFaults`.

Addresses: ``udp:HOST:PORT`` (bind and reply to whoever sent last), ``tcp:HOST:PORT``
(listen; every connected client gets every packet). ``PORT`` 0 picks a free port; read
it back from ``bound_address``.
"""

from __future__ import annotations

import socket
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_harness.errors import LinkAddressError
from sim_harness.faults import FaultConfig, LinkFaults

#: Largest UDP datagram read at once.
MAX_DATAGRAM_BYTES = 65535
#: Cap on datagrams or reads drained per poll (keeps one step bounded).
MAX_READS_PER_POLL = 256
#: Cap on bytes buffered for a slow TCP client before it is dropped.
MAX_TCP_BACKLOG_BYTES = 1 << 20


@dataclass(frozen=True)
class LinkAddress:
    """A parsed ``udp:HOST:PORT`` or ``tcp:HOST:PORT``."""

    kind: str
    host: str
    port: int

    @classmethod
    def parse(cls, text: str) -> LinkAddress:
        """Parse ``udp:127.0.0.1:14550``; raises LinkAddressError naming what is wrong."""
        parts = text.split(":")
        if len(parts) != 3:
            raise LinkAddressError("expected KIND:HOST:PORT, e.g. udp:127.0.0.1:14550", address=text)
        kind, host, port_text = parts
        kind = kind.lower()
        if kind not in ("udp", "udpin", "tcp", "tcpin"):
            raise LinkAddressError(f"kind must be udp or tcp, got {kind!r}", address=text)
        try:
            port = int(port_text)
        except ValueError:
            raise LinkAddressError(f"port {port_text!r} is not a number", address=text) from None
        if not 0 <= port <= 65535:
            raise LinkAddressError(f"port {port} is out of range", address=text)
        if not host:
            raise LinkAddressError("host is empty", address=text)
        return cls(kind.removesuffix("in"), host, port)

    def __str__(self) -> str:
        return f"{self.kind}:{self.host}:{self.port}"


class Transport(Protocol):
    """A polled byte transport."""

    bound_address: tuple[str, int]

    def poll(self) -> list[bytes]:
        """Read everything available now, without blocking."""
        ...

    def send(self, data: bytes) -> None:
        """Send to the peer(s); silently nothing if there is no peer yet."""
        ...

    def close(self) -> None:
        """Release the socket(s)."""
        ...


class UdpServer:
    """UDP server: binds, and replies to the address that sent to it last (like BlueOS)."""

    def __init__(self, host: str, port: int) -> None:
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self._sock.bind((host, port))
        except OSError as exc:
            self._sock.close()
            raise LinkAddressError(f"cannot bind: {exc}", address=f"udp:{host}:{port}") from exc
        self._sock.setblocking(False)
        self.bound_address: tuple[str, int] = self._sock.getsockname()[:2]
        self.peer: tuple[str, int] | None = None

    def poll(self) -> list[bytes]:
        """Datagrams waiting now; remembers the sender as the peer."""
        out: list[bytes] = []
        for _ in range(MAX_READS_PER_POLL):
            try:
                data, addr = self._sock.recvfrom(MAX_DATAGRAM_BYTES)
            except (BlockingIOError, InterruptedError):
                break
            except ConnectionResetError:  # ICMP port unreachable from a vanished peer
                continue
            self.peer = addr[:2]
            out.append(data)
        return out

    def send(self, data: bytes) -> None:
        """Send one datagram to the last peer, if any."""
        if self.peer is None:
            return
        try:
            self._sock.sendto(data, self.peer)
        except (BlockingIOError, InterruptedError, ConnectionRefusedError):
            pass  # a full buffer or a vanished peer loses the packet, as on a real link

    def close(self) -> None:
        """Close the socket."""
        self._sock.close()


class TcpServer:
    """TCP server: accepts clients; sends to all of them, reads from all of them."""

    def __init__(self, host: str, port: int) -> None:
        self._listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self._listener.bind((host, port))
            self._listener.listen(4)
        except OSError as exc:
            self._listener.close()
            raise LinkAddressError(f"cannot listen: {exc}", address=f"tcp:{host}:{port}") from exc
        self._listener.setblocking(False)
        self.bound_address: tuple[str, int] = self._listener.getsockname()[:2]
        self._clients: list[socket.socket] = []
        self._pending: dict[socket.socket, bytearray] = {}

    @property
    def client_count(self) -> int:
        """Number of connected clients."""
        return len(self._clients)

    def _accept(self) -> None:
        for _ in range(8):
            try:
                conn, _addr = self._listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            conn.setblocking(False)
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self._clients.append(conn)
            self._pending[conn] = bytearray()

    def _drop(self, conn: socket.socket) -> None:
        if conn in self._clients:
            self._clients.remove(conn)
        self._pending.pop(conn, None)
        conn.close()

    def poll(self) -> list[bytes]:
        """Accept new clients and read what they sent."""
        self._accept()
        out: list[bytes] = []
        for conn in list(self._clients):
            for _ in range(MAX_READS_PER_POLL):
                try:
                    data = conn.recv(MAX_DATAGRAM_BYTES)
                except (BlockingIOError, InterruptedError):
                    break
                except OSError:
                    self._drop(conn)
                    break
                if not data:
                    self._drop(conn)
                    break
                out.append(data)
        return out

    def send(self, data: bytes) -> None:
        """Queue and flush ``data`` to every client."""
        for conn in list(self._clients):
            buf = self._pending[conn]
            buf += data
            try:
                sent = conn.send(buf)
            except (BlockingIOError, InterruptedError):
                sent = 0
            except OSError:
                self._drop(conn)
                continue
            del buf[:sent]
            if len(buf) > MAX_TCP_BACKLOG_BYTES:
                self._drop(conn)

    def close(self) -> None:
        """Close all sockets."""
        for conn in list(self._clients):
            self._drop(conn)
        self._listener.close()


def open_transport(address: str | LinkAddress) -> UdpServer | TcpServer:
    """Open the server socket for ``address`` (only loopback or explicit hosts)."""
    addr = LinkAddress.parse(address) if isinstance(address, str) else address
    if addr.kind == "udp":
        return UdpServer(addr.host, addr.port)
    return TcpServer(addr.host, addr.port)


class MavlinkPort:
    """MAVLink 2 framing and parsing over a transport, with link faults both ways.

    Parameters
    ----------
    transport
        An open :class:`UdpServer` or :class:`TcpServer`.
    faults
        Link faults to apply; a generator seeded from ``faults.seed`` drives them.
    system_id, component_id
        The vehicle's MAVLink identity (ArduSub: 1, 1).
    """

    def __init__(
        self,
        transport: UdpServer | TcpServer,
        faults: FaultConfig,
        *,
        system_id: int = 1,
        component_id: int = 1,
    ) -> None:
        self.transport = transport
        self._codec = mavlink.MAVLink(None, srcSystem=system_id, srcComponent=component_id)
        self._codec.robust_parsing = True
        seed_seq = np.random.SeedSequence([faults.seed, 0x4C494E4B])
        rx_seed, tx_seed = seed_seq.spawn(2)
        self._faulty = faults.affects_link
        self._rx = LinkFaults(faults, np.random.default_rng(rx_seed))
        self._tx = LinkFaults(faults, np.random.default_rng(tx_seed))
        self.packets_in = 0
        self.packets_out = 0
        self.bad_packets = 0

    @property
    def codec(self) -> mavlink.MAVLink:
        """The dialect object (for ``*_encode`` helpers)."""
        return self._codec

    def receive(self, now_s: float) -> list[mavlink.MAVLink_message]:
        """Messages that have arrived by ``now_s`` (after link faults), in order."""
        chunks = self.transport.poll()
        if self._faulty:
            for chunk in chunks:
                self._rx.push(now_s, chunk)
            chunks = self._rx.pop_due(now_s)
        out: list[mavlink.MAVLink_message] = []
        for chunk in chunks:
            try:
                msgs = self._codec.parse_buffer(chunk)
            except mavlink.MAVError:
                self.bad_packets += 1
                continue
            for msg in msgs or ():
                if msg.get_type() == "BAD_DATA":
                    self.bad_packets += 1
                    continue
                self.packets_in += 1
                out.append(msg)
        return out

    def send(self, messages: list[mavlink.MAVLink_message], now_s: float) -> None:
        """Pack ``messages`` (MAVLink 2) and send them through the link faults."""
        for msg in messages:
            data = msg.pack(self._codec)
            self._codec.seq = (self._codec.seq + 1) % 256
            self.packets_out += 1
            if self._faulty:
                self._tx.push(now_s, data)
            else:
                self.transport.send(data)
        if self._faulty:
            for data in self._tx.pop_due(now_s):
                self.transport.send(data)

    def send_raw(self, data: bytes, now_s: float) -> None:
        """Send bytes another system packed (a peer the router forwards), through the faults."""
        self.packets_out += 1
        if self._faulty:
            self._tx.push(now_s, data)
            for due in self._tx.pop_due(now_s):
                self.transport.send(due)
        else:
            self.transport.send(data)

    def close(self) -> None:
        """Close the transport."""
        self.transport.close()
