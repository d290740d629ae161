"""Fixtures of the vehicle_link tests (the scripted peer lives in vl_peer.py)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest

from tests.vehicle_link.vl_peer import ScriptedVehicle, make_config
from vehicle_link.client import ArduSubClient
from vehicle_link.clock import Clock
from vehicle_link.config import LinkConfig


@pytest.fixture
def peer_factory() -> Iterator[Callable[..., ScriptedVehicle]]:
    peers: list[ScriptedVehicle] = []

    def make(**kwargs: Any) -> ScriptedVehicle:
        p = ScriptedVehicle(**kwargs)
        peers.append(p)
        return p

    yield make
    for p in peers:
        p.close()


@pytest.fixture
def client_factory() -> Iterator[Callable[..., ArduSubClient]]:
    clients: list[ArduSubClient] = []

    def make(config: LinkConfig, *, clock: Clock | None = None, **kwargs: Any) -> ArduSubClient:
        c = ArduSubClient(config, clock=clock, **kwargs)
        clients.append(c)
        return c

    yield make
    for c in clients:
        c.close()


@pytest.fixture
def peer(peer_factory: Callable[..., ScriptedVehicle]) -> ScriptedVehicle:
    return peer_factory()


@pytest.fixture
def client(peer: ScriptedVehicle, client_factory: Callable[..., ArduSubClient]) -> ArduSubClient:
    c = client_factory(make_config(peer))
    c.connect()
    return c
