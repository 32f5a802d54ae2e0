"""A small Groot2 client for the tests: what Groot2 asks a BehaviorTree.CPP ``Groot2Publisher``.

The wire protocol (BehaviorTree.CPP ``include/behaviortree_cpp/loggers/groot2_protocol.h`` and
``src/loggers/groot2_publisher.cpp``): ZeroMQ request-reply on the publisher's port, every message
multipart. A request's first part is 6 bytes: the protocol id (``2``), the request type (``T`` the
tree's XML, ``S`` the status of every node, ...) and a uint32 request id chosen by the client
(little-endian, as the publisher copies it from memory). The reply's first part echoes those 6
bytes and adds the 16-byte id of the tree published; the second part is the answer: the XML
(``T``), or 3 bytes per node (``S``: its uint16 uid, then its status: 0 idle, 1 running, 2 success,
3 failure, 4 skipped; 10 + s when it went idle from status s). An error reply is the two parts
``error`` and the message.
"""

from __future__ import annotations

import random
import struct
from dataclasses import dataclass

import zmq

PROTOCOL = 2
FULL_TREE = b"T"
STATUS = b"S"
_REQUEST = struct.Struct("<BcI")


class GrootError(Exception):
    """The publisher answered with an error, or a reply that does not match the request."""


@dataclass(frozen=True)
class Reply:
    """A reply: the id of the tree published (16 bytes) and the answer."""

    tree_id: bytes
    body: bytes


def statuses(body: bytes) -> dict[int, int]:
    """A status answer as ``{node uid: status}``."""
    if len(body) % 3:
        raise GrootError(f"a status answer has 3 bytes per node, not {len(body)} bytes")
    return {uid: status for uid, status in struct.iter_unpack("<HB", body)}


class GrootClient:
    """Requests to a Groot2 publisher on ``127.0.0.1:port``, each waited for at most ``timeout_s``.

    ZeroMQ connects in the background, so a client may be made before the publisher binds; a
    request that has no answer in time (no publisher yet, or the publisher went away) returns
    ``None`` and the socket is made again, as a request socket cannot send before it has received.
    """

    def __init__(self, port: int, timeout_s: float = 0.5) -> None:
        self.address = f"tcp://127.0.0.1:{port}"
        self.timeout_ms = int(timeout_s * 1000)
        self.context = zmq.Context()
        self.socket = self._connect()

    def _connect(self) -> zmq.Socket[bytes]:
        socket: zmq.Socket[bytes] = self.context.socket(zmq.REQ)
        socket.setsockopt(zmq.LINGER, 0)
        socket.setsockopt(zmq.RCVTIMEO, self.timeout_ms)
        socket.setsockopt(zmq.SNDTIMEO, self.timeout_ms)
        socket.connect(self.address)
        return socket

    def request(self, kind: bytes) -> Reply | None:
        """Ask ``kind`` (:data:`FULL_TREE`, :data:`STATUS`): the reply, or ``None`` without one in time."""
        unique_id = random.getrandbits(32)
        header = _REQUEST.pack(PROTOCOL, kind, unique_id)
        try:
            self.socket.send(header)
            parts = self.socket.recv_multipart()
        except zmq.Again:
            self.socket.close()
            self.socket = self._connect()
            return None
        if parts[0] == b"error":
            raise GrootError(b" ".join(parts[1:]).decode("utf-8", "replace"))
        if len(parts) != 2 or len(parts[0]) != _REQUEST.size + 16:
            raise GrootError(f"unexpected reply: {len(parts)} part(s), a header of {len(parts[0])} bytes")
        protocol, echoed, echoed_id = _REQUEST.unpack(parts[0][: _REQUEST.size])
        if (protocol, echoed, echoed_id) != (PROTOCOL, kind, unique_id):
            raise GrootError(f"the reply answers another request: {(protocol, echoed, echoed_id)}")
        return Reply(parts[0][_REQUEST.size :], parts[1])

    def close(self) -> None:
        self.socket.close()
        self.context.term()

    def __enter__(self) -> GrootClient:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()
