"""The port Foxglove apps reach: a WebSocket front that speaks both names of the Foxglove
WebSocket protocol, relays each client to the foxglove-sdk server on loopback, and keeps what
clients send within bounds.

Why a front: foxglove-sdk 0.30 accepts only the subprotocol name `foxglove.sdk.v1` (a constant
in its handshake, no option) and answers HTTP 400 to `foxglove.websocket.v1`, the name
Foxglove Studio 1.x, Lichtblick up to 1.21 and the npm `@foxglove/ws-protocol` client offer;
the protocol under both names is the same. The front answers with the name the client offered
and relays frames unchanged, so the SDK keeps doing what it does well (channels, subscriptions,
latched messages, backlogs, assets), but for the server's `metadata` it adds to the SDK's
serverInfo (its Python API takes none). What clients publish stops here: its Python API can only
send a status to every client and keeps client channels whatever their size, so the front takes
client advertisements and message data itself and hands them to a `ClientInput`, with a status
channel to that one client.

Bounds, whatever a client sends: a frame over MAX_FRAME_BYTES closes its connection (1009, before
the frame is read); at most MAX_FRAMES_PER_S frames a second are taken from a client (past that,
the rest of that second's are dropped: a Twist is stale once a newer one came, and the front once
read them more slowly, so that a flood's backlog flew commands seconds after the client stopped or
left), and a client sending over CLOSE_AT_FRAMES_PER_S in a second is closed (1008: reading that
many costs a core); at most MAX_CLIENT_CHANNELS advertised channels
and MAX_NAME_CHARS in a name; at most MAX_CLIENTS connections. Problems go to that client as a
status message, at most one a second, and to the log at most one line every LOG_EVERY_S seconds
for all clients together.

One race of the SDK's is mended here: it sends a channel's advertisement before it files the
channel under the client, so a client quick enough to subscribe at once (the npm client on a
loaded machine) is told "Unknown channel ID" for a channel it was just offered. The front knows
which channels the SDK has advertised to each client, so it sends such a subscription again
(RESUBSCRIBE_S later, at most RESUBSCRIBE_TRIES times) instead of passing that answer on; an
answer about a channel never advertised goes to the client as it is.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import logging
import re
import struct
import threading
import time
from collections.abc import Mapping
from typing import Any, Protocol

from websockets.asyncio.client import connect
from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response
from websockets.protocol import State
from websockets.typing import Subprotocol

log = logging.getLogger(__name__)

#: the protocol's names: foxglove-sdk's, and the one older apps and ws-protocol clients offer
SDK_SUBPROTOCOL = "foxglove.sdk.v1"
SUBPROTOCOLS = (SDK_SUBPROTOCOL, "foxglove.websocket.v1")

MAX_FRAME_BYTES = 256 * 1024  # a Twist is 52 bytes in CDR; a subscription to 100 channels ~5 KB
MAX_FRAMES_PER_S = 1000  # the Teleop panel publishes at 10-20 Hz, a joystick node at 50 Hz; ~5 % of a core
CLOSE_AT_FRAMES_PER_S = 10 * MAX_FRAMES_PER_S
MAX_CLIENT_CHANNELS = 16
MAX_NAME_CHARS = 256
MAX_CLIENTS = 16
STATUS_EVERY_S = 1.0
LOG_EVERY_S = 5.0
CLOSE_TIMEOUT_S = 1.0  # for a client's closing handshake, at the end of a run (websockets' default is 10 s)
MAX_STATUS_CHARS = 300
RESUBSCRIBE_S = 0.02  # the SDK files an advertised channel microseconds after sending it
RESUBSCRIBE_TRIES = 3
#: the SDK's answer to a subscription to a channel it has not filed under the client
UNKNOWN_CHANNEL = re.compile(r"Unknown channel ID: (\d+)")
UNKNOWN_CHANNEL_LOG = "attempted to subscribe to unknown channel"  # the line the SDK logs with it

#: client requests the SDK answers (to the asking client alone); anything else is refused here
FORWARDED_OPS = frozenset(
    {
        "subscribe",
        "unsubscribe",
        "fetchAsset",
        "getParameters",
        "setParameters",
        "subscribeParameterUpdates",
        "unsubscribeParameterUpdates",
        "subscribeConnectionGraph",
        "unsubscribeConnectionGraph",
    }
)
CLIENT_MESSAGE_DATA = 0x01  # client binary opcode: channel id u32, payload
FORWARDED_BINARY = frozenset({0x02, 0x03})  # service call request, playback control
STATUS_WARNING = 1
#: where foxglove-sdk 0.30 logs (an error per bad client request); a logger's filter sees only its own records
SDK_LOGGERS = ("foxglove.websocket", "foxglove.websocket.server", "foxglove.websocket.connected_client")


class ClientInput(Protocol):
    """Who takes what clients publish (called on the front's thread)."""

    def advertised(self, client: FrontClient, channel: dict[str, Any]) -> None: ...
    def unadvertised(self, client: FrontClient, channel_id: int) -> None: ...
    def received(self, client: FrontClient, channel_id: int, data: bytes) -> None: ...


class _Every:
    """At most one event every `every_s` seconds; those in between are counted, and the next one
    allowed says how many (`counted` names them)."""

    def __init__(self, every_s: float, counted: str) -> None:
        self.every_s = every_s
        self.counted = counted
        self.next_s = 0.0
        self.skipped = 0

    def allow(self) -> str | None:
        """None when too soon (counted), else what to add to the event: the count since the last."""
        now = time.monotonic()
        if now < self.next_s:
            self.skipped += 1
            return None
        self.next_s = now + self.every_s
        more = f" ({self.skipped} {self.counted})" if self.skipped else ""
        self.skipped = 0
        return more


class _LogLimiter(logging.Filter):
    """One log line every LOG_EVERY_S seconds for all clients, ours and the SDK's (whose server
    logs an error for each bad request a client makes); the rest are counted in the next."""

    def __init__(self) -> None:
        super().__init__()
        self._every = _Every(LOG_EVERY_S, "other problems since the last line, not logged")

    def warning(self, text: str) -> None:
        more = self._every.allow()
        if more is not None:
            log.warning("%s%s", text[:MAX_STATUS_CHARS], more)

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno < logging.WARNING:
            return True
        if UNKNOWN_CHANNEL_LOG in record.getMessage():  # raced ones are mended; the client hears of others
            return False
        more = self._every.allow()
        if more is None:
            return False
        record.msg, record.args = record.getMessage()[:MAX_STATUS_CHARS] + more, ()
        return True


class FrontClient:
    """One connected app: its id, its address, and `tell` for a status to it alone."""

    def __init__(self, client_id: int, ws: ServerConnection, logger: _LogLimiter) -> None:
        self.id = client_id
        self.address = ":".join(map(str, ws.remote_address[:2])) if ws.remote_address else "?"
        self.channels: set[int] = set()  # those it advertised (to publish on)
        self.offered: set[int] = set()  # those the SDK advertised to it
        self.subscribing: dict[int, tuple[int, int]] = {}  # offered channel -> (subscription id, tries)
        self.resending: set[asyncio.Task[None]] = set()
        self._ws = ws
        self._logger = logger
        #: one status a second at most to this client, ours and the SDK's answers
        self.status = _Every(STATUS_EVERY_S, "other problems since the last status, not reported")

    def tell(self, message: str) -> None:
        """A warning status to this client (one a second at most, with the SDK's answers; the
        rest counted in the next), and a line in the log when the log limiter allows."""
        message = message if len(message) <= MAX_STATUS_CHARS else message[: MAX_STATUS_CHARS - 3] + "..."
        self._logger.warning(f"Foxglove client {self.address}: {message}")
        more = self.status.allow()
        if more is None:
            return
        message += more
        text = json.dumps({"op": "status", "level": STATUS_WARNING, "message": message})
        task = asyncio.get_running_loop().create_task(self._ws.send(text))
        task.add_done_callback(lambda t: t.cancelled() or t.exception())  # a closed client is no error


def _short(value: Any) -> str:
    text = value if isinstance(value, str) else repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


class FoxgloveFront:
    """Serves `host:port` in a thread of its own, relaying each client to the foxglove-sdk server
    at `ws://127.0.0.1:upstream_port`; `inputs` takes what clients publish; `metadata` goes into
    the serverInfo clients get. `close` stops it."""

    def __init__(
        self, host: str, port: int, upstream_port: int, inputs: ClientInput, metadata: Mapping[str, str] | None = None
    ) -> None:
        self.upstream = f"ws://127.0.0.1:{upstream_port}"
        self.inputs = inputs
        self.metadata = dict(metadata or {})
        self._ids = itertools.count(1)
        self._admitted: set[ServerConnection] = set()
        self._logger = _LogLimiter()
        for name in SDK_LOGGERS:
            logging.getLogger(name).addFilter(self._logger)
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, name="foxglove-front", daemon=True)
        self._thread.start()

        async def start() -> Server:
            return await serve(
                self._serve,
                host,
                port,
                subprotocols=[Subprotocol(s) for s in SUBPROTOCOLS],
                select_subprotocol=_offered,
                process_request=self._admit,
                max_size=MAX_FRAME_BYTES,
                max_queue=4,
                compression=None,  # images are JPEG already; deflate would cost CPU for nothing
                close_timeout=CLOSE_TIMEOUT_S,
            )

        try:
            self._server = asyncio.run_coroutine_threadsafe(start(), self._loop).result()
        except OSError:
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join()
            raise
        self.port = int(self._server.sockets[0].getsockname()[1])

    def _admit(self, ws: ServerConnection, request: Request) -> Response | None:
        offered = {n.strip() for h in request.headers.get_all("Sec-WebSocket-Protocol") for n in h.split(",")}
        if not offered & set(SUBPROTOCOLS):  # as the SDK answers a client that offers none of its names
            return ws.respond(400, f"offer the subprotocol {' or '.join(SUBPROTOCOLS)}\n")
        self._admitted = {c for c in self._admitted if c.state is not State.CLOSED}
        if len(self._admitted) >= MAX_CLIENTS:
            return ws.respond(503, f"{MAX_CLIENTS} clients are connected already\n")
        self._admitted.add(ws)
        return None

    async def _serve(self, ws: ServerConnection) -> None:
        client = FrontClient(next(self._ids), ws, self._logger)
        try:
            async with connect(
                self.upstream, subprotocols=[Subprotocol(SDK_SUBPROTOCOL)], max_size=None, compression=None
            ) as upstream:
                down = asyncio.create_task(self._downstream(upstream, ws, client))
                try:
                    await self._upstream(ws, upstream, client)
                finally:
                    down.cancel()
                    with contextlib.suppress(asyncio.CancelledError, ConnectionClosed):
                        await down
        except (OSError, ConnectionClosed):
            pass
        finally:
            self._admitted.discard(ws)
            for channel_id in client.channels:
                self.inputs.unadvertised(client, channel_id)

    async def _downstream(self, upstream: Any, ws: ServerConnection, client: FrontClient) -> None:
        """The SDK's frames to the client as they are (send waits while the client is slow, so
        the SDK's backlog for it, bounded and dropping the oldest data, is where they wait),
        but its status answers, one per bad request, at most one a second as ours, and its
        serverInfo with our metadata."""
        async for frame in upstream:
            if isinstance(frame, str):
                if frame.startswith('{"op":"serverInfo"') and self.metadata:
                    info = json.loads(frame)
                    info["metadata"] = {**(info.get("metadata") or {}), **self.metadata}
                    frame = json.dumps(info, separators=(",", ":"))
                elif frame.startswith('{"op":"status"'):
                    if _resubscribed(upstream, client, frame) or client.status.allow() is None:
                        continue
                elif frame.startswith(('{"op":"advertise"', '{"op":"unadvertise"')):
                    _note_offers(client, frame)
            await ws.send(frame)
        await ws.close()

    async def _upstream(self, ws: ServerConnection, upstream: Any, client: FrontClient) -> None:
        """The client's frames: requests the SDK answers go on, what it publishes goes to
        `inputs`, the rest is refused with a status; never more than MAX_FRAMES_PER_S a second
        (the rest of that second's dropped), and a flood past CLOSE_AT_FRAMES_PER_S is closed."""
        window_s, frames = time.monotonic(), 0
        async for frame in ws:
            frames += 1
            if frames > MAX_FRAMES_PER_S:
                now = time.monotonic()
                if now - window_s >= 1.0:
                    window_s, frames = now, 1
                elif frames > CLOSE_AT_FRAMES_PER_S:
                    await ws.close(1008, f"over {CLOSE_AT_FRAMES_PER_S} messages a second")
                    return
                else:
                    client.tell(f"over {MAX_FRAMES_PER_S} messages a second: the rest of this second's are dropped")
                    continue
            try:
                forward = self._text(client, frame) if isinstance(frame, str) else self._binary(client, frame)
            except Exception as exc:  # a case the checks above missed: that client is told, the server goes on
                client.tell(f"a message could not be handled ({type(exc).__name__}); it is ignored")
                continue
            if forward:
                await upstream.send(frame)

    def _text(self, client: FrontClient, frame: str) -> bool:
        try:
            msg = json.loads(frame)
        except (ValueError, RecursionError) as exc:  # json's errors are ValueErrors; deep nesting
            client.tell(f"a message that is not JSON ({type(exc).__name__}) is ignored")
            return False
        op = msg.get("op") if isinstance(msg, dict) else None
        if isinstance(op, str) and op in FORWARDED_OPS:
            if op == "subscribe":
                _note_subscriptions(client, msg.get("subscriptions"))
            return True
        if op == "advertise" and isinstance(msg.get("channels"), list):
            for channel in msg["channels"]:
                self._advertise(client, channel)
        elif op == "unadvertise" and isinstance(msg.get("channelIds"), list):
            for channel_id in msg["channelIds"]:
                if isinstance(channel_id, int) and channel_id in client.channels:
                    client.channels.discard(channel_id)
                    self.inputs.unadvertised(client, channel_id)
        else:
            client.tell(f"a message with op {_short(op)} is not one this server takes; it is ignored")
        return False

    def _advertise(self, client: FrontClient, channel: Any) -> None:
        fields = ("topic", "encoding", "schemaName")
        if not (
            isinstance(channel, dict)
            and isinstance(channel.get("id"), int)
            and 0 <= channel["id"] < 2**32
            and all(isinstance(channel.get(f), str) and len(channel[f]) <= MAX_NAME_CHARS for f in fields)
        ):
            client.tell(
                f"an advertised channel needs an id (u32) and {', '.join(fields)} (text of at most "
                f"{MAX_NAME_CHARS} characters); it is ignored"
            )
            return
        if channel["id"] not in client.channels and len(client.channels) >= MAX_CLIENT_CHANNELS:
            client.tell(
                f"at most {MAX_CLIENT_CHANNELS} advertised channels a client; {_short(channel['topic'])} is ignored"
            )
            return
        client.channels.add(channel["id"])
        self.inputs.advertised(client, channel)

    def _binary(self, client: FrontClient, frame: bytes) -> bool:
        if not frame:
            return False
        if frame[0] in FORWARDED_BINARY:
            return True
        if frame[0] == CLIENT_MESSAGE_DATA and len(frame) >= 5:
            (channel_id,) = struct.unpack_from("<I", frame, 1)
            if channel_id in client.channels:
                self.inputs.received(client, channel_id, bytes(frame[5:]))
            else:
                client.tell(f"message data on channel {channel_id}, which this client has not advertised, is ignored")
            return False
        client.tell(f"a binary message with opcode {frame[0]} is not one this server takes; it is ignored")
        return False

    def close(self) -> None:
        """Closes every connection (a client that does not answer the closing handshake within
        CLOSE_TIMEOUT_S is cut off), then cancels and awaits what is left on the loop, so that no
        handler is left pending to be destroyed, with a traceback, when the process ends."""

        async def stop() -> None:
            for ws in list(self._admitted):  # a client that reads nothing holds its handler in a send (the
                transport = ws.transport  # closing handshake waits behind it): cut off first, or it outlives the loop
                if transport is not None and transport.get_write_buffer_size() > 0:
                    transport.abort()
            await asyncio.sleep(0)  # (their handlers see it)
            self._server.close()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._server.wait_closed(), 2 * CLOSE_TIMEOUT_S)
            left = [t for t in asyncio.all_tasks() if t is not asyncio.current_task()]
            for task in left:
                task.cancel()
            if left:
                await asyncio.wait(left, timeout=CLOSE_TIMEOUT_S)

        if self._thread.is_alive():
            with contextlib.suppress(RuntimeError, TimeoutError):
                asyncio.run_coroutine_threadsafe(stop(), self._loop).result(timeout=4 * CLOSE_TIMEOUT_S)
            self._loop.call_soon_threadsafe(self._loop.stop)
            self._thread.join(timeout=5)
        for name in SDK_LOGGERS:
            logging.getLogger(name).removeFilter(self._logger)


def _offered(ws: ServerConnection, offered: Any) -> Subprotocol | None:
    """The client's first choice among the names we speak."""
    return next((Subprotocol(name) for name in offered if name in SUBPROTOCOLS), None)


def _note_offers(client: FrontClient, frame: str) -> None:
    """The channels the SDK advertises to `client` (or takes back), from its frame."""
    try:
        msg = json.loads(frame)
    except ValueError:
        return
    if msg.get("op") == "advertise":
        client.offered.update(c["id"] for c in msg.get("channels", ()) if isinstance(c.get("id"), int))
    else:
        for channel_id in msg.get("channelIds", ()):
            client.offered.discard(channel_id)
            client.subscribing.pop(channel_id, None)


def _note_subscriptions(client: FrontClient, subscriptions: Any) -> None:
    """The subscriptions `client` asks of the SDK, kept for channels the SDK offered it (so
    bounded by them), in case the SDK has not filed the channel yet."""
    if not isinstance(subscriptions, list):
        return
    for sub in subscriptions:
        if isinstance(sub, dict) and isinstance(sub.get("id"), int) and sub.get("channelId") in client.offered:
            client.subscribing[sub["channelId"]] = (sub["id"], 0)


def _resubscribed(upstream: Any, client: FrontClient, frame: str) -> bool:
    """True when `frame` is the SDK's "Unknown channel ID" about a channel it did advertise to
    `client`, which asked to subscribe: the subscription is sent again a little later, and the
    answer is not passed on."""
    try:
        message = json.loads(frame).get("message")
    except (ValueError, AttributeError):
        return False
    match = UNKNOWN_CHANNEL.fullmatch(message) if isinstance(message, str) else None
    channel_id = int(match.group(1)) if match else None
    if channel_id not in client.offered or channel_id not in client.subscribing:
        return False
    sub_id, tries = client.subscribing[channel_id]
    if tries >= RESUBSCRIBE_TRIES:
        return False
    client.subscribing[channel_id] = (sub_id, tries + 1)
    again = json.dumps({"op": "subscribe", "subscriptions": [{"id": sub_id, "channelId": channel_id}]})

    async def resend() -> None:
        await asyncio.sleep(RESUBSCRIBE_S * (tries + 1))
        with contextlib.suppress(ConnectionClosed):
            await upstream.send(again)

    task = asyncio.get_running_loop().create_task(resend())
    client.resending.add(task)  # the loop holds tasks weakly
    task.add_done_callback(client.resending.discard)
    return True
