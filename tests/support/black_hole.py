"""A TCP proxy that can turn into a black hole: what a client sees when the link to its database dies without a
word (a dropped route, a frozen host, a hung server behind a load balancer).

It forwards both ways until :meth:`BlackHoleProxy.swallow`; from then on it passes nothing on and answers
nothing, yet closes nothing: every connection stays open and what is sent on it is taken (the sender's kernel
sees it acknowledged, so neither TCP's retransmission timeout nor keepalives notice), and new connections are
accepted and get no answer either. :meth:`BlackHoleProxy.forward` passes bytes on again for connections made from
then on (those that lived through the black hole lost bytes and stay dead, as after a real one).
"""

from __future__ import annotations

import socket
import threading


class BlackHoleProxy:
    def __init__(self, target: tuple[str, int]) -> None:
        self.target = target
        self._listener = socket.create_server(("127.0.0.1", 0))
        self.port = self._listener.getsockname()[1]
        self._generation = 0  # connections of an older generation than this passed through a black hole
        self._forwarding = True
        self._lock = threading.Lock()
        self._sockets: list[socket.socket] = []
        threading.Thread(target=self._accept, name="black-hole-accept", daemon=True).start()

    def swallow(self) -> None:
        """From now on nothing passes, nothing is closed."""
        with self._lock:
            self._forwarding = False
            self._generation += 1

    def forward(self) -> None:
        """New connections are forwarded again."""
        with self._lock:
            self._forwarding = True

    def close(self) -> None:
        with self._lock:
            sockets, self._sockets = self._sockets + [self._listener], []
        for sock in sockets:
            # shutdown first: a close alone leaves the socket open while a pump thread is blocked in recv on it, and
            # the server then keeps that session, with the row locks of its open transaction, for later tests
            try:
                sock.shutdown(socket.SHUT_RDWR)
            except OSError:  # never connected, or already gone
                pass
            sock.close()

    def _passes(self, generation: int) -> bool:
        return self._forwarding and generation == self._generation

    def _accept(self) -> None:
        while True:
            try:
                client, _ = self._listener.accept()
            except OSError:  # closed
                return
            with self._lock:
                generation, forwarding = self._generation, self._forwarding
                self._sockets.append(client)
            upstream = None
            if forwarding:
                upstream = socket.create_connection(self.target)
                with self._lock:
                    self._sockets.append(upstream)
                threading.Thread(target=self._pump, args=(upstream, client, generation), daemon=True).start()
            threading.Thread(target=self._pump, args=(client, upstream, generation), daemon=True).start()

    def _pump(self, source: socket.socket, sink: socket.socket | None, generation: int) -> None:
        while True:
            try:
                data = source.recv(65536)
            except OSError:
                return
            if not data:
                if sink is not None and self._passes(generation):
                    sink.close()
                return
            if sink is not None and self._passes(generation):
                try:
                    sink.sendall(data)
                except OSError:
                    return
