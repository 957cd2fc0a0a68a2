"""The ROS 2 bridge: a run's topics published live to a ROS 2 graph, and Twist commands taken from it.

quadsim speaks the DDS wire protocol that every ROS 2 middleware speaks, through Eclipse Cyclone
DDS's Python package (the `ros2` extra), with ROS 2's naming: topic `/quad/odom` is DDS topic
`rt/quad/odom`, type `nav_msgs/msg/Odometry` is `nav_msgs::msg::dds_::Odometry_`. The fan-out's
CDR bytes go out as they are (they are what a ROS 2 publisher sends), so nothing is encoded twice
and no ROS installation is needed. `ROS_DOMAIN_ID` and `ROS_AUTOMATIC_DISCOVERY_RANGE` (or the
older `ROS_LOCALHOST_ONLY`) are honoured as ROS 2 Jazzy and Kilted read them; a `CYCLONEDDS_URI` the
user set wins over the discovery range. The bridge is the node `/quadsim` of the graph (it
publishes `ros_discovery_info` as rmw implementations do), in a namespace and with topics remapped
as `--ros-args` would.

Cyclone is told to ignore the XTypes type information of eProsima Fast DDS endpoints and match
them by type name, as rmw implementations matched before XTypes: Fast DDS 3 (ROS 2 Kilted's default
middleware) announces TypeObjects whose collection members (fixed arrays and sequences: covariances,
`data`, `dim`) carry element flags 0, an invalid "try construct" value that Cyclone's type lookup
rejects, so every reader of such a type stayed unresolved and never matched; types without
collections hash identically on both sides and matched anyway, which is why /clock and /quad/pose
got through and /quad/odom did not.
"""

from __future__ import annotations

import logging
import os
import re
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from functools import cache
from importlib import import_module
from pathlib import Path
from typing import TYPE_CHECKING, Any

from quadsim.core.invocation import install_extra
from quadsim.errors import QuadsimError
from quadsim.live.dds_types import dds_type_name, idl_type
from quadsim.recording.contract import GOALS, TWIST, Topic
from quadsim.recording.fanout import NS_PER_S, Message

if TYPE_CHECKING:
    from quadsim.drivers.subscribed import SubscribedDriver

CLOCK = Topic("/clock", "rosgraph_msgs/msg/Clock")
#: topics a namespace leaves alone: ROS 2 nodes use them by absolute name (tf2, rcl's logging, use_sim_time)
GLOBAL_TOPICS = frozenset({"/clock", "/tf", "/tf_static", "/rosout"})
#: the node this bridge is on the ROS 2 graph (`ros2 node list`)
NODE_NAME = "quadsim"
MAX_DOMAIN_ID = 232  # ROS 2's limit for the default port mapping

#: eProsima's DDSI vendor id (Fast DDS), whose type information Cyclone ignores (see above)
EPROSIMA_VENDOR_ID = "1.15"
_COMPATIBILITY_CONFIG = (
    '<CycloneDDS><Domain Id="any"><Compatibility><IgnoreTypeInformation>{vendors}</IgnoreTypeInformation>'
    "</Compatibility></Domain></CycloneDDS>"
)
_LOCALHOST_CONFIG = (
    '<CycloneDDS><Domain Id="any"><General><Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
    "<AllowMulticast>false</AllowMulticast></General><Discovery><ParticipantIndex>auto</ParticipantIndex>"
    "<MaxAutoParticipantIndex>64</MaxAutoParticipantIndex>{peers}</Discovery></Domain></CycloneDDS>"
)

#: SUBNET (ROS 2's default): Cyclone's multicast discovery on the machine's network, plus the loopback
#: interface, well-known unicast ports and 127.0.0.1 as a peer, so a node that limits itself to
#: LOCALHOST (Fast DDS then only knocks on 127.0.0.1's well-known ports) still finds quadsim
_SUBNET_CONFIG = (
    '<CycloneDDS><Domain Id="any"><General><Interfaces><NetworkInterface autodetermine="true"/>'
    '<NetworkInterface address="127.0.0.1"/></Interfaces></General><Discovery><ParticipantIndex>auto'
    '</ParticipantIndex><MaxAutoParticipantIndex>64</MaxAutoParticipantIndex><Peers><Peer address="127.0.0.1"/>'
    "</Peers></Discovery></Domain></CycloneDDS>"
)


log = logging.getLogger(__name__)


def cyclonedds() -> Any:
    """The cyclonedds package, or a one-line error saying how to install it."""
    try:
        import cyclonedds.domain
    except ImportError:
        raise QuadsimError(
            f"--ros2 and --input ros2 need Eclipse Cyclone DDS for Python: {install_extra('ros2')}"
        ) from None
    import cyclonedds

    return cyclonedds


def domain_id(env: Mapping[str, str]) -> int:
    """ROS_DOMAIN_ID, 0 when unset, as ROS 2 reads it."""
    text = env.get("ROS_DOMAIN_ID", "").strip()
    if not text:
        return 0
    if not text.isdigit() or int(text) > MAX_DOMAIN_ID:
        raise QuadsimError(f"ROS_DOMAIN_ID must be a whole number from 0 to {MAX_DOMAIN_ID}, got {text!r}")
    return int(text)


def discovery_config(env: Mapping[str, str]) -> str | None:
    """The Cyclone DDS configuration for ROS 2's discovery range: LOCALHOST (or ROS_LOCALHOST_ONLY=1)
    keeps discovery and traffic on the loopback interface, OFF finds no other process; SUBNET (ROS 2's
    default) is Cyclone's default (multicast on the network). None: Cyclone's own (or CYCLONEDDS_URI)."""
    wanted = discovery_range(env)
    if env.get("CYCLONEDDS_URI") or wanted == "SUBNET":
        return None
    if wanted not in ("LOCALHOST", "OFF"):
        raise QuadsimError(f"ROS_AUTOMATIC_DISCOVERY_RANGE must be SUBNET, LOCALHOST or OFF, got {wanted!r}")
    peers = [p.strip() for p in env.get("ROS_STATIC_PEERS", "").split(";") if p.strip()]
    if wanted == "LOCALHOST":
        peers.insert(0, "127.0.0.1")
    xml_peers = "".join(f'<Peer address="{p}"/>' for p in peers)
    return _LOCALHOST_CONFIG.format(peers=f"<Peers>{xml_peers}</Peers>" if xml_peers else "")


def cyclone_configs(env: Mapping[str, str]) -> list[str]:
    """The whole Cyclone DDS configuration, best first: type matching by name with Fast DDS, the
    discovery range, then the user's CYCLONEDDS_URI (Cyclone reads a comma-separated list, later
    entries winning). For SUBNET, the second is Cyclone's plain default, for a machine whose only
    interface is the loopback one (Cyclone refuses to be given it twice)."""
    compatibility = _COMPATIBILITY_CONFIG.format(vendors=EPROSIMA_VENDOR_ID)
    if env.get("CYCLONEDDS_URI"):
        return [f"{compatibility},{env['CYCLONEDDS_URI']}"]
    discovery = discovery_config(env)
    if discovery:
        return [f"{compatibility},{discovery}"]
    if not _network_is_up():
        return [compatibility]
    return [f"{compatibility},{_SUBNET_CONFIG}", compatibility]


def _network_is_up() -> bool:
    """Whether an interface other than the loopback one is up (Linux says so in /sys; elsewhere
    assume it is, the plain default being the fallback): with none, Cyclone picks the loopback
    interface itself and complains when given it twice."""
    interfaces = Path("/sys/class/net")
    if not interfaces.is_dir():
        return True
    for folder in interfaces.iterdir():
        try:
            if folder.name != "lo" and (folder / "operstate").read_text().strip() == "up":
                return True
        except OSError:
            continue
    return False


def discovery_range(env: Mapping[str, str]) -> str:
    """The discovery range in ROS 2's words (SUBNET, LOCALHOST, OFF), or what CYCLONEDDS_URI says."""
    if env.get("CYCLONEDDS_URI"):
        return "as CYCLONEDDS_URI configures it"
    wanted = env.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "").strip().upper()
    if not wanted and env.get("ROS_LOCALHOST_ONLY", "").strip() == "1":
        wanted = "LOCALHOST"
    return "SUBNET" if wanted in ("", "SYSTEM_DEFAULT") else wanted


def graph_names(namespace: str = "", remaps: Sequence[str] = ()) -> tuple[str, dict[str, str]]:
    """The node's namespace (`/` when none) and the remapping rules `FROM:=TO` as ROS 2's
    `--ros-args -r` reads them, each side expanded to a fully qualified name as rcl does: a
    relative name lands in the namespace, `~/x` in the node's own (/NS/quadsim/x); a rule may
    name the node first (`quadsim:FROM:=TO`). quadsim's topics are relative names (in the
    namespace) but for /clock, /tf, /tf_static and /rosout, so under a namespace a rule whose
    FROM is neither in it nor one of those could never match: refused, with the rule that would."""
    ns = "/" + namespace.strip("/") if namespace.strip("/") else "/"
    if not _NAME.fullmatch(ns):
        raise QuadsimError(f"--ros-namespace must be a ROS 2 name like /robot1, got {namespace!r}")
    rules: dict[str, str] = {}
    for rule in remaps:
        source, sep, target = rule.removeprefix(f"{NODE_NAME}:").partition(":=")
        fqn_source, fqn_target = _expanded(source, ns), _expanded(target, ns)
        if not sep or fqn_source is None or fqn_target is None:
            raise QuadsimError(
                f"a remapping is FROM:=TO with ROS 2 topic names, like /quad_cmd_twist:=/cmd_vel; got {rule!r}"
            )
        if ns != "/" and fqn_source not in GLOBAL_TOPICS and not fqn_source.startswith(ns + "/"):
            raise QuadsimError(
                f"--ros-remap {rule}: under --ros-namespace {ns.lstrip('/')} quadsim's topics are in {ns} (all but "
                f"{', '.join(sorted(GLOBAL_TOPICS))}), so {fqn_source} names none of them (ROS 2 would ignore the "
                f"rule); write {ns}{fqn_source}:={target} or {fqn_source.lstrip('/')}:={target}"
            )
        rules[fqn_source] = fqn_target
    return ns, rules


def _expanded(name: str, ns: str) -> str | None:
    """A topic name made fully qualified in namespace `ns` (None: not a ROS 2 topic name)."""
    if name.startswith("~"):
        name = f"{ns.rstrip('/')}/{NODE_NAME}{name[1:]}"
    elif not name.startswith("/"):
        name = f"{ns.rstrip('/')}/{name}"
    return name if _NAME.fullmatch(name) and name != "/" else None


def graph_topic(name: str, namespace: str, rules: Mapping[str, str]) -> str:
    """A contract topic's name on the graph (namespace and rules from `graph_names`): its fully
    qualified name, in the namespace (but for /clock, /tf, /tf_static and /rosout, which ROS 2
    nodes name absolutely), then remapped if a rule matches that name."""
    fqn = name if namespace == "/" or name in GLOBAL_TOPICS else namespace + name
    return rules.get(fqn, fqn)


_NAME = re.compile(r"/|(/[A-Za-z_][A-Za-z0-9_]*)+")


def _qos_numbers(topic: Topic) -> tuple[bool, int]:
    """(transient local, history depth) of a contract topic, read off its offered_qos_profiles."""
    durability = re.search(r"durability: (\d+)", topic.qos)
    depth = re.search(r"depth: (\d+)", topic.qos)
    return (durability is not None and durability.group(1) == "1", int(depth.group(1)) if depth else 10)


def dds_topic_name(name: str) -> str:
    """`/quad/odom` -> `rt/quad/odom`."""
    return "rt" + name


_DOMAINS: dict[int, Any] = {}  # a Cyclone domain is configured once per process
_DOMAINS_LOCK = threading.Lock()


class Ros2Bridge:
    """A TopicConsumer of the fan-out that publishes every topic it is given on a ROS 2 graph
    (except `exclude`), plus /clock; and, on request, a Twist subscription feeding a driver.

    Topics keep the contract's QoS: reliable, keep-last; the latched ones (/tf_static,
    /robot_description, /world/markers, /rosout) transient-local, so a node started later still
    gets them. Use as a context manager, or call `close`.
    """

    #: the fan-out names meshes by file:// URLs for it: RViz reads files, not data: URLs
    reads_local_files = True

    def __init__(
        self,
        exclude: Sequence[str] = (),
        env: Mapping[str, str] | None = None,
        namespace: str = "",
        remaps: Sequence[str] = (),
    ) -> None:
        env = os.environ if env is None else env
        self.namespace, self._remaps = graph_names(namespace, remaps)
        dds = cyclonedds()
        from cyclonedds.core import Policy, Qos
        from cyclonedds.domain import Domain, DomainParticipant

        self.domain_id = domain_id(env)
        configs = cyclone_configs(env)
        self.discovery_range = discovery_range(env)
        with _DOMAINS_LOCK:
            for k, config in enumerate(configs):
                if self.domain_id in _DOMAINS:
                    break
                try:
                    _DOMAINS[self.domain_id] = Domain(self.domain_id, config)
                except dds.core.DDSException as e:
                    if k == len(configs) - 1:
                        raise QuadsimError(f"could not join ROS 2 domain {self.domain_id}: {e}") from None
        # IgnoreLocal: the Twist this bridge republishes (keyboard input) must not come back to it
        # user data as rmw implementations set it, read by ROS 2 tools (the security enclave)
        qos = Qos(Policy.IgnoreLocal.Participant, Policy.Userdata(b"enclave=/;"))
        self._participant: Any = DomainParticipant(self.domain_id, qos=qos)
        self._Qos, self._Policy = Qos, Policy
        self.exclude = frozenset(exclude)
        self._writers: dict[str, tuple[Any, Any]] = {}  # topic name -> (writer, IDL type)
        self._readers: list[Any] = []
        self._lock = threading.Lock()  # the sim thread and a replay thread may both publish
        self._clock_ns = -1  # the last /clock published
        self.published = 0  # messages written
        self.busy_s = 0.0  # time spent writing (for the benchmark)
        self.closed = False
        self._graph_writer = self._discovery_info_writer()
        self._time_type = idl_type("builtin_interfaces/msg/Time")
        self.add_topic(CLOCK)

    def graph_name(self, name: str) -> str:
        """A contract topic's name on the graph (graph_topic): in the namespace, then remapped."""
        return graph_topic(name, self.namespace, self._remaps)

    def startup_lines(
        self, takes_twist: bool | Sequence[str], goal_topics: Sequence[str] | None = None
    ) -> list[tuple[str, bool]]:
        """What to say at start-up: (line, is a warning). The node, its domain and discovery range,
        where it takes Twists (on /quad_cmd_twist, or on the topics given: a fleet's) and goal
        poses (the contract's, or `goal_topics`: a fleet vehicle's under its name); a warning when
        it takes them and discovery reaches beyond this machine."""
        node = f"{self.namespace.rstrip('/')}/{NODE_NAME}"
        topics = [TWIST.name] if takes_twist is True else list(takes_twist or ())
        twist = " and ".join(self.graph_name(t) for t in topics)
        taken = [goal.name for goal in GOALS] if goal_topics is None else goal_topics
        goals = " and ".join(self.graph_name(topic) for topic in taken)
        if len(topics) > 1:
            goals = "each vehicle's " + " and ".join(goal.name.lstrip("/") for goal in GOALS)
        takes = f"; it takes geometry_msgs/Twist on {twist} and goal poses on {goals}" if takes_twist else ""
        lines = [
            (
                f"ROS 2: node {node} on domain {self.domain_id} (discovery range {self.discovery_range}), "
                f"publishing every recorded topic and /clock{takes}",
                False,
            )
        ]
        if takes_twist and self.discovery_range not in ("LOCALHOST", "OFF"):
            what = "this vehicle" if len(topics) == 1 else "these vehicles"
            lines.append(
                (
                    f"ROS 2 discovery is not limited to this machine: anyone on the network can fly {what} on "
                    f"{twist} (export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST to keep it here)",
                    True,
                )
            )
        return lines

    # --- the ROS 2 graph ------------------------------------------------------------------------

    def _discovery_info_writer(self) -> Any:
        """The writer of ros_discovery_info, where every rmw implementation says which nodes its
        participant holds and which readers and writers each node owns: what `ros2 node list` and
        `ros2 topic info -v` read. Reliable, transient-local, depth 1, as rmw_dds_common has it."""
        from cyclonedds.pub import DataWriter
        from cyclonedds.topic import Topic as DdsTopic

        kind = _graph_types()[2]
        topic = DdsTopic(self._participant, "ros_discovery_info", kind)
        return DataWriter(self._participant, topic, qos=self._qos(1, latched=True))

    def _qos(self, depth: int, reliable: bool = True, latched: bool | None = None) -> Any:
        """Keep last `depth`, reliable (else best effort), and transient local or volatile as
        `latched` says (None: Cyclone's default, volatile)."""
        Policy = self._Policy
        reliability = (
            Policy.Reliability.Reliable(max_blocking_time=100_000_000) if reliable else Policy.Reliability.BestEffort
        )
        if latched is None:
            return self._Qos(reliability, Policy.History.KeepLast(depth))
        if not latched:
            return self._Qos(reliability, Policy.History.KeepLast(depth), Policy.Durability.Volatile)
        # what a node started later gets is kept by the durability service, whose history is its
        # own (Cyclone's default: the last 1): the same depth, as rmw_cyclonedds sets it
        unlimited = -1
        kept = Policy.DurabilityService(0, Policy.History.KeepLast(depth), unlimited, unlimited, unlimited)
        return self._Qos(reliability, Policy.History.KeepLast(depth), Policy.Durability.TransientLocal, kept)

    def _announce(self) -> None:
        """Publish this participant's node and its endpoints (after each new endpoint).

        Fast DDS 2 (Jazzy) files a remote endpoint under its participant's GUID, so `ros2 topic info
        -v` names quadsim's. Fast DDS 3 (Kilted) files it under the participant GUID its SEDP
        announcement carries (PID_PARTICIPANT_GUID, an optional parameter), which Cyclone never
        sends (its SEDP writes the endpoint GUID alone, with no setting to add it), so there every
        endpoint is under GUID zero and shows as "_CREATED_BY_BARE_DDS_APP_". Announcing the node
        under GUID zero as well was tried: Kilted then names /quadsim, but both distributions list
        /quadsim twice, and the entry stays in every node's graph after quadsim exits (a graph
        cache drops a participant's entry when that participant leaves; GUID zero never does)."""
        gid_type, node_type, info_type = _graph_types()
        endpoints = [w for w, _ in self._writers.values()]
        info = info_type(
            gid=_gid(gid_type, self._participant.guid),
            node_entities_info_seq=[
                node_type(
                    node_namespace=self.namespace,
                    node_name=NODE_NAME,
                    reader_gid_seq=[_gid(gid_type, r.guid) for r in self._readers],
                    writer_gid_seq=[_gid(gid_type, w.guid) for w in endpoints],
                )
            ],
        )
        self._graph_writer.write(info)

    # --- TopicConsumer ------------------------------------------------------------------------

    def add_topic(self, topic: Topic) -> None:
        if topic.name in self.exclude or topic.name in self._writers:
            return
        from cyclonedds.pub import DataWriter
        from cyclonedds.topic import Topic as DdsTopic

        latched, depth = _qos_numbers(topic)
        kind = idl_type(topic.type_name)
        dds_topic = DdsTopic(self._participant, dds_topic_name(self.graph_name(topic.name)), kind)
        writer = DataWriter(self._participant, dds_topic, qos=self._qos(depth, latched=latched))
        self._writers[topic.name] = (writer, kind)
        self._announce()

    def on_messages(self, messages: Sequence[Message]) -> None:
        if self.closed or not messages:
            return
        started = time.perf_counter()
        with self._lock:
            for topic, _ns, data in messages:
                if topic.name == CLOCK.name:  # a bag's own /clock: this bridge's comes from on_clock alone
                    continue
                entry = self._writers.get(topic.name)
                if entry is None:
                    if topic.name in self.exclude:
                        continue
                    self.add_topic(topic)
                    entry = self._writers[topic.name]
                writer, kind = entry
                writer.write(_raw(kind, data))
                self.published += 1
        self.busy_s += time.perf_counter() - started

    def on_event(self, step: int, kind: str, value: str, vehicle: str = "") -> None:
        """Events reach the graph as their /rosout messages."""

    def on_clock(self, ns: int, seek: bool = False) -> None:
        """/clock: simulation time from the fan-out's states (or a replay's playback), at the state
        rate, strictly increasing; back in time only when told it is a seek (a replay moved back, a
        window's reset), as `ros2 bag play` does. Never from the messages themselves: camera frames
        arrive after the states that followed them, stamped with the instant they show."""
        if self.closed or (ns <= self._clock_ns and not seek):
            return
        started = time.perf_counter()
        with self._lock:
            entry = self._writers.get(CLOCK.name)
            if entry is None:  # closed meanwhile
                return
            writer, kind = entry
            writer.write(kind(clock=self._time_type(sec=ns // NS_PER_S, nanosec=ns % NS_PER_S)))
            self._clock_ns = ns
        self.busy_s += time.perf_counter() - started

    # --- input --------------------------------------------------------------------------------

    def subscribe_twist(self, driver: SubscribedDriver, on_twist: Callable[[], None] | None = None) -> None:
        """Feed `driver` the geometry_msgs/Twist messages on its topic (/quad_cmd_twist, or a fleet
        vehicle's /NAME/quad_cmd_twist), as they arrive."""

        def on_sample(twist: Any) -> None:
            taken = driver.deliver((twist.linear.x, twist.linear.y, twist.linear.z), twist.angular.z)
            if not taken and driver.rejected == 1:  # once: the summary counts the rest
                log.warning(
                    "a Twist on %s with a field that is not finite is ignored (the summary counts any more)",
                    driver.heard_on,
                )
            if on_twist is not None:
                on_twist()

        driver.heard_on = self.graph_name(driver.topic)
        self._read(driver.heard_on, TWIST.type_name, 10, on_sample)

    def subscribe_goals(
        self, driver: SubscribedDriver, on_publishers: Callable[[str, int], None] | None = None
    ) -> None:
        """Feed `driver` the geometry_msgs/PoseStamped goals on its goal topics (/goal_pose and
        /move_base_simple/goal, or a fleet vehicle's under its name), as they arrive. The first
        goal refused is logged with its reason; the summary counts the rest (a node sending bad
        goals cannot flood the log). `on_publishers(topic, count)` is told (on Cyclone's thread)
        each time the number of goal publishers heard on a topic changes; a publisher that cannot
        be heard (best effort) is warned about once per topic."""

        def taker(name: str) -> Callable[[Any], None]:
            def on_sample(goal: Any) -> None:
                p, q = goal.pose.position, goal.pose.orientation
                why = driver.deliver_goal(goal.header.frame_id, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
                if why is not None and driver.goals_rejected == 1:
                    log.warning("a goal on %s is ignored: %s (the summary counts any more)", name, why)

            return on_sample

        for topic in driver.goal_topics:
            # reliable: a goal comes once (RViz publishes one per click), and a best-effort reader
            # loses it with any lost packet. A goal written before this reader has matched its
            # writer is lost all the same (DDS gives a volatile reader only what is written after
            # the match): `on_publishers` says when a publisher is heard.
            name = self.graph_name(topic)
            self._read(name, "geometry_msgs/msg/PoseStamped", 1, taker(name), reliable=True, heard=on_publishers)

    def _read(
        self,
        topic: str,
        type_name: str,
        depth: int,
        on_sample: Callable[[Any], None],
        reliable: bool = False,
        heard: Callable[[str, int], None] | None = None,
    ) -> None:
        """Call `on_sample` with each `type_name` message on the graph's `topic` as it arrives (on
        Cyclone's receive thread). Best effort by default, so reliable and best-effort publishers
        both match (a stream of Twists, where the next one replaces a lost one); `reliable` for a
        message sent once, which then only reliable publishers (ROS 2's default) deliver: one that
        is not is warned about, once. `heard(topic, count)`: the publishers matched, as it changes."""
        from cyclonedds.core import Listener
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic as DdsTopic

        kind = idl_type(type_name)

        def on_data_available(reader: Any) -> None:
            for sample in reader.take(32):
                if isinstance(sample, kind):  # not an invalid sample (a writer gone)
                    on_sample(sample)

        def on_subscription_matched(reader: Any, status: Any) -> None:
            if heard is not None and status.current_count_change:
                heard(topic, int(status.current_count))

        def on_requested_incompatible_qos(reader: Any, status: Any) -> None:
            if status.total_count == 1:  # once: a node re-created in a loop cannot flood the log
                log.warning(
                    "a publisher on %s is not heard: its QoS does not match this reader's (%s; publish "
                    "reliably, as ROS 2 does by default)",
                    topic,
                    "reliable, keep last" if reliable else "best effort, keep last",
                )

        qos = self._qos(depth, reliable)
        dds_topic = DdsTopic(self._participant, dds_topic_name(topic), kind)
        listener = Listener(
            on_data_available=on_data_available,
            on_subscription_matched=on_subscription_matched,
            on_requested_incompatible_qos=on_requested_incompatible_qos,
        )
        self._readers.append(DataReader(self._participant, dds_topic, qos=qos, listener=listener))
        with self._lock:
            self._announce()

    # --- lifetime -----------------------------------------------------------------------------

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        with self._lock:
            self._readers.clear()
            self._writers.clear()
            self._graph_writer = None
            self._participant = None  # Cyclone deletes the participant and its entities with it

    def __enter__(self) -> Ros2Bridge:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _gid(gid_type: Any, guid: Any) -> Any:
    """An rmw_dds_common/Gid from a DDS GUID (uuid.UUID): its 16 bytes, as rmw implementations fill it."""
    return gid_type(data=list(guid.bytes))


@cache
def _graph_types() -> tuple[Any, Any, Any]:
    """rmw_dds_common's Gid, NodeEntitiesInfo and ParticipantEntitiesInfo as Cyclone IDL types
    (rosbags' typestore does not carry rmw_dds_common; the definitions are three lines of .msg)."""
    from cyclonedds.idl import make_idl_struct

    types: Any = import_module("cyclonedds.idl.types")  # its generic aliases are not typed as such
    array, bounded_str, sequence = types.array, types.bounded_str, types.sequence
    gid = make_idl_struct("Gid", dds_type_name("rmw_dds_common/msg/Gid"), {"data": array[types.uint8, 16]})
    node = make_idl_struct(
        "NodeEntitiesInfo",
        dds_type_name("rmw_dds_common/msg/NodeEntitiesInfo"),
        {
            "node_namespace": bounded_str[256],
            "node_name": bounded_str[256],
            "reader_gid_seq": sequence[gid],
            "writer_gid_seq": sequence[gid],
        },
    )
    info = make_idl_struct(
        "ParticipantEntitiesInfo",
        dds_type_name("rmw_dds_common/msg/ParticipantEntitiesInfo"),
        {"gid": gid, "node_entities_info_seq": sequence[node]},
    )
    return gid, node, info


def _raw(kind: Any, data: bytes) -> Any:
    """A sample of IDL type `kind` that serializes to `data` (CDR with its encapsulation header, as
    the fan-out made it): DataWriter.write takes an instance of the topic's type and asks it for
    its bytes."""
    sample = object.__new__(kind)
    sample.serialize = lambda **_: data
    return sample
