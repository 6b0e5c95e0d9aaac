"""Minimal Foxglove WebSocket clients over plain sockets, for the live view's tests and
bench: a handshake (with or without a key), a subscription to one topic, and then either
reading what comes or never reading again (a slow subscriber). Not a test module."""

import base64
import json
import os
import socket
import struct

__all__ = ["handshake", "read_frame", "subscribe", "stalled_subscriber"]

SUBPROTOCOL = "foxglove.sdk.v1"


def handshake(port: int, query: str = "", recv_buffer: int | None = None) -> socket.socket:
    """A socket connected to ``127.0.0.1:port`` with the WebSocket handshake sent (the
    answer not read). ``recv_buffer`` shrinks the receive buffer (a slow client's)."""
    sock = socket.socket()
    if recv_buffer is not None:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, recv_buffer)
    sock.settimeout(30)
    sock.connect(("127.0.0.1", port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall(
        (
            f"GET /{query} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
            f"Sec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: {SUBPROTOCOL}\r\n\r\n"
        ).encode()
    )
    return sock


def answer_head(sock: socket.socket) -> bytes:
    """The HTTP answer to the handshake, up to its blank line."""
    head = b""
    while b"\r\n\r\n" not in head:
        chunk = sock.recv(1)
        if not chunk:
            break
        head += chunk
    return head


def _exactly(sock: socket.socket, n: int) -> bytes:
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            raise EOFError("closed")
        data += chunk
    return data


def read_frame(sock: socket.socket) -> tuple[int, bytes]:
    """One server frame: its opcode and payload."""
    head = _exactly(sock, 2)
    length = head[1] & 0x7F
    if length == 126:
        (length,) = struct.unpack("!H", _exactly(sock, 2))
    elif length == 127:
        (length,) = struct.unpack("!Q", _exactly(sock, 8))
    return head[0] & 0x0F, _exactly(sock, length)


def _send_text(sock: socket.socket, text: str) -> None:
    payload = text.encode()
    mask = os.urandom(4)
    masked = bytes(b ^ mask[i % 4] for i, b in enumerate(payload))
    length = len(payload)
    head = bytes([0x81]) + (
        bytes([0x80 | length]) if length < 126 else bytes([0x80 | 126]) + struct.pack("!H", length)
    )
    sock.sendall(head + mask + masked)


def subscribe(sock: socket.socket, topic: str) -> None:
    """Read the server's advertisements until ``topic``'s, and subscribe to it."""
    while True:
        opcode, payload = read_frame(sock)
        if opcode != 0x1:
            continue
        message = json.loads(payload)
        if message.get("op") != "advertise":
            continue
        for channel in message["channels"]:
            if channel["topic"] == topic:
                request = {
                    "op": "subscribe",
                    "subscriptions": [{"id": 1, "channelId": channel["id"]}],
                }
                _send_text(sock, json.dumps(request))
                return


def stalled_subscriber(port: int, topic: str, query: str = "") -> socket.socket:
    """A client subscribed to ``topic`` that will never read again (its receive buffer
    small, so the server's sends back up at once)."""
    sock = handshake(port, query, recv_buffer=4096)
    head = answer_head(sock)
    assert b" 101 " in head.split(b"\r\n", 1)[0], head
    subscribe(sock, topic)
    return sock
