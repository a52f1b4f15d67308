"""The live view's front door: Foxglove's WebSocket protocol under both of its names.

foxglove-sdk's server accepts only the subprotocol ``foxglove.sdk.v1`` and answers a client that offers
``foxglove.websocket.v1`` (older Foxglove and Lichtblick releases, foxglove_bridge 0.8 clients, ws-protocol
libraries) with HTTP 400. The two are one protocol under two names (Foxglove's stance, discussion 1131), so
the relay accepts either on the live view's port and passes every frame unchanged to and from the SDK's
server, which listens on a private loopback port.
"""
from __future__ import annotations

import asyncio
import threading

SUBPROTOCOLS = ("foxglove.sdk.v1", "foxglove.websocket.v1")   # in the server's order of preference
START_TIMEOUT = 10.0   # [s] to bind the port, and to close
CLOSE_TIMEOUT = 1.0    # [s] a WebSocket's closing handshake: a half-dead client does not hold the node's end
CLIENT_MESSAGE_MAX = 1 << 20   # [bytes] what a client sends is subscriptions: the listener buffers no more


async def _pipe(source, sink):
    from websockets.exceptions import ConnectionClosed
    try:
        async for frame in source:
            await sink.send(frame)
    except ConnectionClosed:   # a client gone mid-frame is a client gone
        pass


class SubprotocolRelay:
    """A WebSocket server on ``host:port`` (0: any free one, in ``self.port``) relaying each client to
    ``ws://127.0.0.1:upstream_port`` with ``foxglove.sdk.v1``; it runs its own event loop in a thread."""

    def __init__(self, host: str, port: int, upstream_port: int):
        from websockets.asyncio.server import serve
        self.upstream = f"ws://127.0.0.1:{upstream_port}"
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, name="live_view_relay", daemon=True)
        self.thread.start()
        async def start():   # serve() wants the loop it runs in
            return await serve(self._client, host, port, subprotocols=list(SUBPROTOCOLS),
                               max_size=CLIENT_MESSAGE_MAX, close_timeout=CLOSE_TIMEOUT)
        try:
            self.server = asyncio.run_coroutine_threadsafe(start(), self.loop).result(START_TIMEOUT)
        except BaseException:
            self._stop_loop()
            raise
        self.port = self.server.sockets[0].getsockname()[1]

    async def _client(self, client):
        from websockets.asyncio.client import connect
        async with connect(self.upstream, subprotocols=[SUBPROTOCOLS[0]], max_size=None,
                           close_timeout=CLOSE_TIMEOUT) as upstream:
            legs = [asyncio.ensure_future(_pipe(client, upstream)), asyncio.ensure_future(_pipe(upstream, client))]
            _, pending = await asyncio.wait(legs, return_when=asyncio.FIRST_COMPLETED)
            for leg in pending:   # one side closed: the other goes with it
                leg.cancel()

    def stop(self):
        async def close():
            self.server.close()
            await self.server.wait_closed()
            for task in asyncio.all_tasks() - {asyncio.current_task()}:   # a client's legs still relaying
                task.cancel()
        try:
            asyncio.run_coroutine_threadsafe(close(), self.loop).result(START_TIMEOUT)
        except Exception:  # noqa: BLE001 -- a close that does not finish in time still ends the loop below
            pass
        finally:
            self._stop_loop()

    def _stop_loop(self):
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(START_TIMEOUT)
        if not self.thread.is_alive():
            self.loop.close()
