"""The Foxglove bridge: a Foxglove WebSocket server (foxglove-sdk) that streams a run's topics
live and takes the Twists a client publishes on /quad_cmd_twist (Foxglove's Teleop panel).

A consumer of the topic fan-out: its channels are the recording's (CDR messages, `ros2msg`
schemas, the QoS in `offered_qos_profiles`), in a foxglove Context of its own, so the server
sees none of a recorder's channels and a recorder none of its clients. Latched topics (those
offered transient-local with depth 1: /tf_static, the robot description, the world markers)
keep their last message, and a client that subscribes to one gets it then, whenever it
connects. foxglove-sdk 0.30's Python `Client` names no sink id (the C++ and Rust APIs do), so
that message goes to every subscriber of the channel: the others get again the message they
already have, unchanged.

Clients reach it through `FoxgloveFront` (foxglove_front.py), which speaks the protocol under
both its names (`foxglove.websocket.v1` for Foxglove Studio 1.x, Lichtblick <= 1.21 and the npm
ws-protocol client; `foxglove.sdk.v1` for current apps) and relays each client to the SDK server
on loopback; the front hands this bridge what clients publish, with a status line to that client
alone. Clients may publish on /quad_cmd_twist in `json` (what the Foxglove app sends, as the
server lists it first) or `cdr`, and goals (geometry_msgs/PoseStamped, the 3D panel's "publish
pose") on the input's goal topics (/move_base_simple/goal, /goal_pose; quadsim.drivers.goal). The
other topics Foxglove's 3D panel advertises on connect (PANEL_TOPICS) are taken quietly and
ignored; anything else is refused with a status message to that client.
"""

from __future__ import annotations

import ipaddress
import json
import logging
import math
import threading
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import foxglove
from foxglove.websocket import Capability, ChannelView, Client, ServerListener

from quadsim.errors import QuadsimError
from quadsim.live import FOXGLOVE_DEFAULT_HOST as DEFAULT_HOST
from quadsim.live import FOXGLOVE_DEFAULT_PORT as DEFAULT_PORT
from quadsim.live.foxglove_front import FoxgloveFront
from quadsim.recording import cdr
from quadsim.recording.contract import QOS_LATCHED, TWIST, Topic
from quadsim.recording.writer import ros2_channel_log, route_sdk_logs_through_python

if TYPE_CHECKING:
    from quadsim.drivers.subscribed import SubscribedDriver
    from quadsim.live.foxglove_front import FrontClient
    from quadsim.recording.fanout import Message

log = logging.getLogger(__name__)

#: encodings a client may publish Twists in, the Foxglove app's choice first (it takes the first
#: of the server's list it knows)
PUBLISH_ENCODINGS = ("json", "cdr")

TwistFields = tuple[tuple[float, float, float], float]  # linear x y z, angular z

#: what Foxglove's 3D panel advertises on every connect (its publish tools: click a point, a
#: pose estimate, a goal) and ROS 2's Nav2 goal topic: taken quietly where no input flies them
#: (a run without --input foxglove; a pose estimate, a clicked point)
PANEL_TOPICS = frozenset({"/clicked_point", "/move_base_simple/goal", "/initialpose", "/goal_pose"})
#: told to clients in serverInfo's metadata: the ROS 2 distribution quadsim's messages are those
#: of (its ROS 2 node is checked against Jazzy and Kilted). Foxglove Studio 1.x and Lichtblick take
#: a server that names one for a ROS 2 source, and only there does their 3D panel offer its publish
#: tools (publish point, pose, pose estimate)
SERVER_METADATA = {"ROS_DISTRO": "jazzy"}
#: the SDK's per-client queue of outgoing messages: oldest data dropped past it (its default is
#: 1024, ~50 MB of camera frames for a client that stopped reading)
BACKLOG_MESSAGES = 256


def parse_endpoint(text: str) -> tuple[str, int]:
    """`HOST:PORT`, `HOST`, `:PORT` or `PORT` (IPv6 as `[::1]:PORT`) -> (host, port); the
    default host is 127.0.0.1 and the default port 8765. Port 0 lets the system choose."""
    text = text.strip()
    host, port_text = DEFAULT_HOST, str(DEFAULT_PORT)
    if text.startswith("["):  # [IPv6]:PORT
        end = text.find("]")
        if end < 0 or (text[end + 1 :] and not text[end + 1 :].startswith(":")):
            raise QuadsimError(f"--foxglove {text!r}: expected HOST:PORT, e.g. 127.0.0.1:8765 or [::1]:8765")
        host, port_text = text[1:end], text[end + 2 :] or port_text
    elif text.count(":") == 1:
        host, port_text = text.split(":")
        host = host or DEFAULT_HOST
    elif text.isdigit():
        port_text = text
    elif text and ":" not in text:
        host = text
    else:
        raise QuadsimError(f"--foxglove {text!r}: expected HOST:PORT, e.g. 127.0.0.1:8765 or [::1]:8765")
    if not port_text.isdigit() or not 0 <= int(port_text) <= 65535 or not host or any(c.isspace() for c in host):
        raise QuadsimError(f"--foxglove {text!r}: expected HOST:PORT with a port within 0..65535, e.g. 127.0.0.1:8765")
    return host, int(port_text)


def twist_from_json(data: bytes) -> TwistFields:
    """A geometry_msgs/Twist as the Foxglove app sends it in JSON; a field left out is 0, as in
    a ROS message. ValueError for anything else."""
    msg = json.loads(data)
    if not isinstance(msg, dict):
        raise ValueError("not a JSON object")
    x, y, z = _numbers(msg, "linear", "xyz")
    return (x, y, z), _numbers(msg, "angular", "xyz")[2]


def _numbers(parent: dict[str, Any], name: str, fields: str, where: str = "") -> list[float]:
    """The fields (one letter each) of the JSON object `name` in `parent`, a field left out 0.
    ValueError, naming it as `where` + `name`, for anything else."""
    v = parent.get(name) or {}
    if not isinstance(v, dict):
        raise ValueError(f"{where}{name} is not an object")
    values = [v.get(f, 0.0) for f in fields]
    if not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in values):
        raise ValueError(f"{where}{name} has a field that is not a number")
    return [float(x) for x in values]


def twist_from_cdr(data: bytes) -> TwistFields:
    lx, ly, lz, _, _, az = cdr.twist_fields(data)
    return (lx, ly, lz), az


DECODERS: dict[str, Callable[[bytes], TwistFields]] = {"json": twist_from_json, "cdr": twist_from_cdr}

PoseFields = tuple[str, tuple[float, float, float], tuple[float, float, float, float]]


def pose_from_json(data: bytes) -> PoseFields:
    """A geometry_msgs/PoseStamped as the Foxglove app sends it in JSON (frame_id, position,
    orientation x y z w); a field left out is 0 (an orientation left out: none). ValueError for
    anything else."""
    msg = json.loads(data)
    header, pose = (msg.get("header") or {}, msg.get("pose") or {}) if isinstance(msg, dict) else (None, None)
    if not isinstance(header, dict) or not isinstance(pose, dict):
        raise ValueError("not a PoseStamped object")
    frame_id = header.get("frame_id", "")
    if not isinstance(frame_id, str):
        raise ValueError("header.frame_id is not a string")
    x, y, z = _numbers(pose, "position", "xyz", "pose.")
    qx, qy, qz, qw = _numbers(pose, "orientation", "xyzw", "pose.")
    return frame_id[: cdr.MAX_FRAME_ID_BYTES], (x, y, z), (qx, qy, qz, qw)


POSE_DECODERS: dict[str, Callable[[bytes], PoseFields]] = {"json": pose_from_json, "cdr": cdr.pose_stamped_fields}


def _reason(exc: BaseException) -> str:
    """A decoding error in a few words: never the client's whole message back."""
    if isinstance(exc, RecursionError):
        return "nested too deeply"
    if isinstance(exc, OverflowError):
        return "a number too large for a float64"
    text = str(exc)
    return text if len(text) <= 80 else text[:77] + "..."


class FoxgloveBridge(ServerListener):
    """A Foxglove WebSocket server fed by the topic fan-out (a `TopicConsumer`), and the listener of
    that server (`on_subscribe`; ServerListener's other callbacks do nothing). With `commands` (one
    driver, or a fleet's, each on its vehicle's topic), clients may publish Twists on their topics,
    which it `deliver`s to the driver of the topic; without, the server takes nothing from clients.
    `close` stops the server."""

    def __init__(
        self,
        host: str = DEFAULT_HOST,
        port: int = DEFAULT_PORT,
        commands: SubscribedDriver | Sequence[SubscribedDriver] | None = None,
        name: str = "quadsim",
    ) -> None:
        drivers = [] if commands is None else [commands] if not isinstance(commands, Sequence) else list(commands)
        #: topic -> the driver Twists published on it go to
        self.inputs: dict[str, SubscribedDriver] = {d.topic: d for d in drivers}
        #: goal topic -> the driver goals published on it go to
        self.goal_inputs: dict[str, SubscribedDriver] = {t: d for d in drivers for t in d.goal_topics}
        self._context = foxglove.Context()  # the server's channels, apart from a recorder's
        self._log: dict[str, Callable[..., None]] = {}  # topic -> its channel's log(data, log_time, sink_id)
        self._latched: dict[str, tuple[int, bytes]] = {}  # topic -> its last (log time, message)
        self._latched_topics: set[str] = set()
        # (client, channel) -> its decoder, the driver its messages go to, and whether they are goals
        self._publishers: dict[tuple[int, int], tuple[Callable[[bytes], Any], SubscribedDriver, bool]] = {}
        self._lock = threading.Lock()
        self.closed = False
        route_sdk_logs_through_python()  # before the first sink starts, or it has no effect
        # the SDK serves loopback only, the front the address asked for (clients publish to the front)
        self.server = foxglove.start_server(
            name=name,
            host="127.0.0.1",
            port=0,
            capabilities=[Capability.ClientPublish] if self.inputs else [],
            server_listener=self,
            supported_encodings=list(PUBLISH_ENCODINGS) if self.inputs else None,
            context=self._context,
            message_backlog_size=BACKLOG_MESSAGES,
        )
        try:
            self.front = FoxgloveFront(host, port, int(self.server.port), self, SERVER_METADATA)
        except OSError as exc:
            self.server.stop()
            reason = (exc.strerror or str(exc)).lower()
            raise QuadsimError(f"--foxglove {host}:{port}: cannot serve there ({reason})") from None
        self.host = host
        self.port = self.front.port  # the one the system chose, for port 0

    @property
    def exposed(self) -> bool:
        """Served beyond this machine: anyone who can reach the port can watch (and, with
        commands, fly)."""
        try:
            return not ipaddress.ip_address(self.host).is_loopback
        except ValueError:  # a host name: loopback only if it is localhost
            return self.host != "localhost"

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"

    # --- what the fan-out calls -----------------------------------------------------------------

    def add_topic(self, topic: Topic) -> None:
        if topic.name in self._log:
            return
        self._log[topic.name] = ros2_channel_log(topic, self._context)
        if topic.qos == QOS_LATCHED:
            self._latched_topics.add(topic.name)

    def on_messages(self, messages: Sequence[Message]) -> None:
        if self.closed:
            return
        log_to, latched = self._log, self._latched_topics
        for topic, ns, data in messages:
            if topic.name in latched:
                with self._lock:
                    self._latched[topic.name] = (ns, data)
            log_to[topic.name](data, ns)

    def on_event(self, step: int, kind: str, value: str, vehicle: str = "") -> None:
        """Events reach clients as /rosout messages; nothing else to do."""

    # --- what clients do (on the server's threads) ------------------------------------------

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        """A latched topic's last message to a client that subscribes to it."""
        with self._lock:
            last = self._latched.get(channel.topic)
        if last is not None and not self.closed:
            ns, data = last
            # to this client alone where the SDK names its sink; else to the channel's subscribers
            self._log[channel.topic](data, ns, sink_id=getattr(client, "sink_id", None))

    # --- what clients publish (the front calls these on its thread) ------------------------------

    def advertised(self, client: FrontClient, channel: dict[str, Any]) -> None:
        topic = channel["topic"]
        goal_driver = self.goal_inputs.get(topic)
        if goal_driver is not None and channel["schemaName"].endswith("PoseStamped"):
            pose_decoder = POSE_DECODERS.get(channel["encoding"])
            if pose_decoder is not None:
                self._publishers[(client.id, channel["id"])] = (pose_decoder, goal_driver, True)
                return
        if topic in PANEL_TOPICS:
            return
        decoder = DECODERS.get(channel["encoding"])
        driver = self.inputs.get(topic)
        if driver is None or decoder is None or not channel["schemaName"].endswith("Twist"):
            takes = (
                f"takes only {TWIST.type_name} on {' or '.join(self.inputs)}, in {' or '.join(PUBLISH_ENCODINGS)}"
                if self.inputs
                else "takes no messages from clients (run it with --input foxglove to fly)"
            )
            client.tell(f"quadsim {takes}; {topic} ({channel['schemaName']}, {channel['encoding']}) is ignored")
            return
        self._publishers[(client.id, channel["id"])] = (decoder, driver, False)

    def unadvertised(self, client: FrontClient, channel_id: int) -> None:
        self._publishers.pop((client.id, channel_id), None)

    def received(self, client: FrontClient, channel_id: int, data: bytes) -> None:
        publisher = self._publishers.get((client.id, channel_id))
        if publisher is None:
            return
        decoder, driver, goal = publisher
        try:
            fields = decoder(data)
        except (ValueError, TypeError, OverflowError, RecursionError) as exc:  # json's errors are ValueErrors
            what = "a goal was not a PoseStamped" if goal else f"a message on {driver.topic} was not a Twist"
            client.tell(f"{what} ({_reason(exc)}); it is ignored")
            return
        if goal:
            why = driver.deliver_goal(*fields)
            if why is not None:
                client.tell(f"a goal is ignored: {why}")  # quadsim's words, a frame name cut to 64 at most
        elif not driver.deliver(*fields) and not all(map(math.isfinite, (*fields[0], fields[1]))):
            client.tell(f"a Twist on {driver.topic} with a field that is not finite is ignored")

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        self.front.close()
        self.server.stop()
