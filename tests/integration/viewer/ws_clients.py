#!/usr/bin/env python3
"""N WebSocket clients of fieldline-viewer's /ws for a while, each reading every state document
as a browser would receive it; prints per client the documents and bytes received and the rate.

  ws_clients.py PORT N SECONDS
"""
import base64
import os
import selectors
import socket
import struct
import sys
import time

port, count, seconds = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])


def connect():
    sock = socket.create_connection(("127.0.0.1", port), timeout=5)
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall((f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                  f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                  "Sec-WebSocket-Version: 13\r\n\r\n").encode())
    head = b""
    while b"\r\n\r\n" not in head:
        head += sock.recv(1)
    if b" 101 " not in head.split(b"\r\n")[0]:
        raise RuntimeError(f"upgrade refused: {head[:60]!r}")
    sock.setblocking(False)
    return sock


class Client:
    def __init__(self):
        self.sock = connect()
        self.buffer = bytearray()
        self.documents = 0
        self.bytes = 0

    def on_readable(self):
        self.buffer += self.sock.recv(1 << 20)
        offset = 0  # whole frames out of the buffer, without copying it per frame
        while len(self.buffer) - offset >= 2:
            flags, length = self.buffer[offset], self.buffer[offset + 1] & 0x7F
            header = 2
            if length == 126:
                header = 4
            elif length == 127:
                header = 10
            if len(self.buffer) - offset < header:
                break
            if length == 126:
                length = struct.unpack_from(">H", self.buffer, offset + 2)[0]
            elif length == 127:
                length = struct.unpack_from(">Q", self.buffer, offset + 2)[0]
            if len(self.buffer) - offset < header + length:
                break
            # Beast fragments long messages: a document ends with a FIN frame.
            if flags & 0x80:
                self.documents += 1
            self.bytes += length
            offset += header + length
        del self.buffer[:offset]


clients = [Client() for _ in range(count)]
selector = selectors.DefaultSelector()
for c in clients:
    selector.register(c.sock, selectors.EVENT_READ, c)
start = time.monotonic()
while time.monotonic() - start < seconds:
    for key, _ in selector.select(timeout=0.1):
        key.data.on_readable()
elapsed = time.monotonic() - start
for i, c in enumerate(clients):
    print(f"client {i + 1}: {c.documents} documents ({c.documents / elapsed:.1f}/s), "
          f"{c.bytes / c.documents / 1024 if c.documents else 0:.1f} KiB each")
