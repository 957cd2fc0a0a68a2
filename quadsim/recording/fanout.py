"""One topic fan-out per run: every vehicle's commands, states, camera frames, joystick input and
events become the recording contract's messages once, and every consumer gets the same messages.

A message is (topic, log time in ns of simulation time, CDR bytes), with header.stamp equal to
its log time. Consumers (the MCAP recorder, the ROS 2 and Foxglove bridges) choose nothing: which
messages a state becomes is decided here alone. The run's fan-out (`TopicFanout`) holds the
consumers, the topics and the latched messages; each vehicle's producer (`VehicleTopics`, a loop
sink and a camera-frame sink) turns what that vehicle does into messages under its names (a run
of one vehicle: the contract's own). Each producer hands its messages over in log-time order (a
state's five at once); frames rendered in other processes arrive when they are ready, as they
would on a live bus.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from functools import lru_cache
from typing import NamedTuple, Protocol

import numpy as np

from quadsim.core.kinematics import body_velocity, quaternion_from_matrix
from quadsim.core.types import LidarMode, Twist, VehicleState
from quadsim.physics.world_spec import WorldSpec
from quadsim.recording import cdr
from quadsim.recording.contract import (
    BODY_FRAME,
    JOY,
    LIDAR_FRAME,
    POINTS,
    RANGE,
    RANGE_FRAME,
    ROBOT_DESCRIPTION,
    ROBOT_MARKERS,
    ROSOUT,
    SCAN,
    SEGMENTATION_LABELS,
    STATE_TOPICS,
    TF_STATIC,
    TWIST,
    WIND,
    WORLD_FRAME,
    WORLD_MARKERS,
    Names,
    Topic,
    frame_topics,
    optical_rotation,
)
from quadsim.recording.scene import link_transforms, robot_description, robot_markers, world_markers
from quadsim.sensors.beams import Ranges, beam_directions, frame_rotation, xyz_points
from quadsim.sensors.camera import CameraFrame, CameraSpec
from quadsim.sensors.images import depth_colormap_jpeg, segment_names
from quadsim.vehicle.params import CameraMount, RangeParams, VehicleParams

NS_PER_S = 1_000_000_000
JOY_FRAME = "joy"
#: the `name` of the /rosout messages quadsim itself writes
LOGGER_NAME = "quadsim"
#: event kinds logged at WARN level on /rosout (the rest are INFO)
WARNING_EVENTS = frozenset({"crash"})


#: (topic, log time in ns, CDR bytes with their encapsulation header); a plain tuple, as
#: building a named one costs more than encoding some of the messages
Message = tuple[Topic, int, bytes]


#: the names of a run of one vehicle: the contract's, unchanged
ONE_VEHICLE = Names()


class TopicConsumer(Protocol):
    """What the fan-out feeds."""

    def add_topic(self, topic: Topic) -> None:
        """A topic messages will come on; announced once, before its first message."""

    def on_messages(self, messages: Sequence[Message]) -> None:
        """Messages from one producer, in log-time order (a state's messages come together)."""

    def on_event(self, step: int, kind: str, value: str, vehicle: str = "") -> None:
        """Something a re-simulation must know besides the commands (a z-mode switch), at `step`,
        of `vehicle` in a fleet. Its /rosout message comes through `on_messages` as well."""


class ClockConsumer(TopicConsumer, Protocol):
    """A consumer that also follows the simulation clock (the ROS 2 bridge's /clock): a
    TopicConsumer with `on_clock`, which the fan-out calls when it has one."""

    def on_clock(self, ns: int, seek: bool = False) -> None:
        """Simulation time is now `ns`: called at the state rate, before that state's messages,
        strictly increasing. Camera frames are not ticks (they arrive late, stamped with the
        instant they show). `seek`: a replay moved back (or looped); time starts again at `ns`."""


@lru_cache(maxsize=16)
def _thrusts_encoder(rotors: int) -> Callable[[Sequence[float]], bytes]:
    """/quad/rotor_thrusts: one value per rotor, labelled."""
    return cdr.float64_multi_array_encoder((cdr.ArrayDimension("rotor", rotors, rotors),), rotors)


class _Camera(NamedTuple):
    spec: CameraSpec
    frame: str  # its optical frame's name on the wire
    topics: dict[str, Topic]  # by kind (contract.CAMERA_TOPICS), those it has, under the vehicle's names


def _image(ns: int, frame_id: str, encoding: str, pixels: np.ndarray) -> bytes:
    """One channel of pixels -> sensor_msgs/Image, little-endian (is_bigendian 0)."""
    height, width = pixels.shape
    data = np.ascontiguousarray(pixels, dtype=pixels.dtype.newbyteorder("<")).tobytes()
    return cdr.image(ns, frame_id, height, width, encoding, width * pixels.itemsize, data)


class TopicFanout:
    """A run's fan-out: its consumers, the topics announced so far and the latched messages (one
    /tf_static with every vehicle's links, each vehicle's robot description and model markers,
    the world's markers),
    fed by each vehicle's producer (`add_vehicle`). With no consumer it does nothing.

    A consumer added at any time gets every topic announced so far, then the latched messages, as
    a late joiner of a live graph needs them (one message a latched topic keeps)."""

    def __init__(self, physics_hz: int, world: WorldSpec | None = None) -> None:
        self.physics_hz = physics_hz
        self._world = world
        self.consumers: list[TopicConsumer] = []
        #: each vehicle's producer, in the run's order
        self.vehicles: list[VehicleTopics] = []
        self._announced: list[Topic] = []  # what producers declared since they were made
        self._known: set[str] = {WORLD_MARKERS.name} if world is not None else set()  # every topic's name so far
        self._clocks: list[ClockConsumer] = []  # the consumers that follow the clock
        #: the simulation time of the newest state handed over, in ns (-1: none yet)
        self.clock_ns = -1

    def add_vehicle(
        self,
        names: Names = ONE_VEHICLE,
        cameras: Sequence[tuple[CameraSpec, CameraMount]] = (),
        vehicle: VehicleParams | None = None,
        range_finder: RangeParams | None = None,
        lidar: LidarMode | None = None,
    ) -> VehicleTopics:
        """A vehicle's producer: its topics under `names` (a run of one vehicle: the contract's),
        its cameras' images and infos, and with `vehicle` its links and robot description, and
        its range finder's (as it flies: its noise 0 in a run without) and LiDAR's if it carries them. Every vehicle is added before the
        first consumer (which gets their latched messages)."""
        if self.consumers:
            raise RuntimeError("a run's vehicles are added to its fan-out before its consumers")
        topics = VehicleTopics(self, names, cameras, vehicle, range_finder, lidar)
        self.vehicles.append(topics)
        self._known.update(topic.name for topic in topics.topics)
        return topics

    @property
    def topics(self) -> list[Topic]:
        """Every topic announced so far: each vehicle's own in the run's order (with /tf_static
        once), the world's markers, then what was declared since, in that order."""
        seen: dict[str, Topic] = {}
        for vehicle in self.vehicles:
            for topic in vehicle.topics:
                seen.setdefault(topic.name, topic)
        if self._world is not None:
            seen.setdefault(WORLD_MARKERS.name, WORLD_MARKERS)
            if self.segment_names:
                seen.setdefault(SEGMENTATION_LABELS.name, SEGMENTATION_LABELS)
        for topic in self._announced:
            seen.setdefault(topic.name, topic)
        return list(seen.values())

    def latched(self, step: int = 0, local_files: bool = False) -> tuple[Message, ...]:
        """The latched messages (transient local), stamped at `step`: every consumer gets them
        first, whenever it joins. `local_files`: the URDF and the markers name meshes by file://
        URLs (for a consumer whose readers read files, as RViz does), not data: URLs (scene.py)."""
        ns = self.ns(step)
        static = [t._replace(ns=ns) for vehicle in self.vehicles for t in vehicle.static_transforms]
        messages: list[Message] = [(TF_STATIC, ns, cdr.tf_message(static))]
        for vehicle in self.vehicles:
            messages += vehicle.own_latched(step, local_files)
        if self._world is not None:
            messages.append((WORLD_MARKERS, ns, cdr.marker_array(world_markers(self._world, ns))))
            if self.segment_names:
                messages.append((SEGMENTATION_LABELS, ns, cdr.string(json.dumps(list(self.segment_names)))))
        return tuple(messages)

    @property
    def segment_names(self) -> tuple[str, ...]:
        """The legend of the segmentation images (label id i is names[i]), in a run with a
        segmenting camera and a world; else ()."""
        if self._world is None or not any(v.segmenting for v in self.vehicles):
            return ()
        return segment_names(self._world, [v.names.vehicle for v in self.vehicles])

    # --- consumers ----------------------------------------------------------------------------

    def add_consumer(self, consumer: TopicConsumer, step: int = 0) -> None:
        """Start feeding `consumer` from `step` on: the topics so far, then the latched messages
        (stamped at `step`, so a recording started mid-run begins when it began)."""
        for topic in self.topics:
            consumer.add_topic(topic)
        consumer.on_messages(self.latched(step, getattr(consumer, "reads_local_files", False)))
        self.consumers.append(consumer)
        if callable(getattr(consumer, "on_clock", None)):
            self._clocks.append(consumer)  # type: ignore[arg-type]  # it has on_clock: a ClockConsumer

    def remove_consumer(self, consumer: TopicConsumer) -> None:
        if consumer in self.consumers:
            self.consumers.remove(consumer)
        if consumer in self._clocks:
            self._clocks.remove(consumer)

    def declare(self, topic: Topic) -> None:
        """Announce a topic that not every run has (/joy when a joystick drives, /wind, /rosout)."""
        if topic.name not in self._known:
            self._known.add(topic.name)
            self._announced.append(topic)
            for consumer in self.consumers:
                consumer.add_topic(topic)

    def ns(self, step: int) -> int:
        """Log time of a physics step: floor(step * 1e9 / physics_hz)."""
        return step * NS_PER_S // self.physics_hz

    def tick(self, ns: int) -> None:
        """The simulation clock reached `ns` (a state's time): the clock's consumers hear of it
        once, when it moves forward. In a fleet every vehicle's state of a step ticks; the first
        one counts. A state older than the clock only comes after a reset to step 0 (the
        window's R), which is said as a seek."""
        if ns == self.clock_ns:
            return
        seek = ns < self.clock_ns
        self.clock_ns = ns
        for consumer in self._clocks:
            consumer.on_clock(ns, seek)

    def publish(self, messages: Sequence[Message]) -> None:
        """Hand `messages` (in log-time order) to every consumer."""
        for consumer in self.consumers:
            consumer.on_messages(messages)

    def note_event(self, step: int, kind: str, value: str, vehicle: str = "", logger: str = LOGGER_NAME) -> None:
        """An event -> /rosout (a crash as a warning) as `logger`'s, and `on_event` for consumers
        that keep it apart (a re-flight switches z-mode where it says); `vehicle`: the vehicle of
        a fleet it is about ("": the run's, or the one vehicle's)."""
        if not self.consumers:
            return
        self.declare(ROSOUT)
        ns = self.ns(step)
        level = cdr.LogLevel.WARN if kind in WARNING_EVENTS else cdr.LogLevel.INFO
        message = (ROSOUT, ns, cdr.log(ns, level, logger, f"{kind}: {value}"))
        for consumer in self.consumers:
            if vehicle:
                consumer.on_event(step, kind, value, vehicle)
            else:  # as before fleets: a consumer written for one vehicle takes three
                consumer.on_event(step, kind, value)
            consumer.on_messages((message,))


class VehicleTopics:
    """One vehicle's producer: a loop sink (commands, states, flight events) and a camera-frame
    sink that turns what it receives into the contract's messages, under the vehicle's names
    (contract.Names: in a fleet, its name in front of its topics and frames), and hands them to
    the run's fan-out. With no consumer it does nothing."""

    def __init__(
        self,
        fanout: TopicFanout,
        names: Names = ONE_VEHICLE,
        cameras: Sequence[tuple[CameraSpec, CameraMount]] = (),
        vehicle: VehicleParams | None = None,
        range_finder: RangeParams | None = None,
        lidar: LidarMode | None = None,
    ) -> None:
        """`range_finder`: the vehicle's range finder as it flies (its [range]; noise 0 in a run
        without); `lidar`: the scan its LiDAR ([lidar]) makes. None: it carries none."""
        self.fanout = fanout
        self.names = names
        t, body = names.topic, names.frame(BODY_FRAME)
        self._twist, self._joy, self._wind = t(TWIST), t(JOY), t(WIND)
        self._description, self._markers = t(ROBOT_DESCRIPTION), t(ROBOT_MARKERS)
        self._state_topics = tuple(t(topic) for topic in STATE_TOPICS)
        self._logger = f"{names.vehicle}.{LOGGER_NAME}" if names.vehicle else LOGGER_NAME
        self._joy_frame = names.frame(JOY_FRAME)
        # the encoders of the state's messages, compiled for their frames
        self._pose = cdr.pose_stamped_encoder(WORLD_FRAME)
        self._odometry = cdr.odometry_encoder(WORLD_FRAME, body)
        self._imu = cdr.imu_encoder(body)
        self._tf = cdr.transform_encoder(WORLD_FRAME, body)
        self._cameras = {
            spec.name: _Camera(
                spec, names.frame(spec.optical_frame), {k: names.topic(t) for k, t in frame_topics(spec).items()}
            )
            for spec, _ in cameras
        }
        self._infos = {spec.name: spec.camera_info() for spec, _ in cameras}
        #: whether a camera of this vehicle makes segmentation images
        self.segmenting = any(spec.segmentation for spec, _ in cameras)
        #: this vehicle's topics, in the order consumers get them (/tf_static is the run's, shared)
        self.topics: list[Topic] = [self._twist, *self._state_topics, TF_STATIC]
        for camera in self._cameras.values():
            self.topics += camera.topics.values()
        static = link_transforms(vehicle) if vehicle is not None else []
        static += [
            cdr.TransformStamped(
                0, BODY_FRAME, spec.optical_frame, mount.position_m, quaternion_from_matrix(optical_rotation(mount))
            )
            for spec, mount in cameras
        ]
        if (range_finder is not None or lidar is not None) and vehicle is None:
            raise ValueError("a range finder's or LiDAR's topics need the vehicle's parameters")
        static += self._ranging(names, vehicle, range_finder, lidar)
        #: base_link -> every URDF link and camera (stamped when sent)
        self.static_transforms = [
            s._replace(frame_id=names.frame(s.frame_id), child_frame_id=names.frame(s.child_frame_id)) for s in static
        ]
        self._urdf_path = vehicle.urdf_path if vehicle is not None else None
        # by local_files, made when first asked for: the description's bytes, the unstamped markers
        self._robot_description: dict[bool, bytes] = {}
        self._robot_markers: dict[bool, list[cdr.Marker]] = {}
        self.topics += [self._description, self._markers] if vehicle is not None else []

    def _ranging(
        self, names: Names, vehicle: VehicleParams | None, r: RangeParams | None, lidar: LidarMode | None
    ) -> list[cdr.TransformStamped]:
        """The range finder's and the LiDAR's topics and encoders, where the vehicle carries them;
        their frames' static transforms from base_link."""
        static: list[cdr.TransformStamped] = []
        self._range = self._scan = None
        if vehicle is None:
            return static
        if r is not None:
            self._range = names.topic(RANGE)
            range_encoder = cdr.range_encoder(
                names.frame(RANGE_FRAME),
                r.radiation_type.wire,
                r.field_of_view_rad,
                r.min_range_m,
                r.max_range_m,
                r.noise_std_m**2,
            )
            self._range_message = lambda ns, ranges: range_encoder(ns, float(ranges[0]))
            self.topics.append(self._range)
            static.append(cdr.TransformStamped(0, BODY_FRAME, RANGE_FRAME, r.position_m, frame_rotation(r.direction)))
        if lidar is not None:
            p, frame = vehicle.lidar, names.frame(LIDAR_FRAME)
            static.append(cdr.TransformStamped(0, BODY_FRAME, LIDAR_FRAME, p.position_m, (0.0, 0.0, 0.0, 1.0)))
            if lidar is LidarMode.PLANAR:
                increment = 2.0 * math.pi / p.samples
                angles = (-math.pi, -math.pi + (p.samples - 1) * increment, increment)
                # every beam of a scan is cast at once: no time between them
                scan = cdr.laser_scan_encoder(frame, angles, (0.0, 1.0 / p.rate_hz), (p.min_range_m, p.max_range_m))
                self._scan = names.topic(SCAN)
                self._scan_message = lambda ns, ranges: scan(ns, ranges.astype("<f4").tobytes())
            else:
                cloud, beams = cdr.xyz_cloud_encoder(frame), beam_directions(p, lidar)
                self._scan = names.topic(POINTS)
                self._scan_message = lambda ns, ranges: cloud(ns, xyz_points(beams, ranges).astype("<f4").tobytes())
            self.topics.append(self._scan)
        return static

    def own_latched(self, step: int, local_files: bool = False) -> tuple[Message, ...]:
        """The latched messages that are this vehicle's alone: its robot description and its
        model as markers in its own frames (in a fleet, with its name over it)."""
        if self._urdf_path is None:
            return ()
        if local_files not in self._robot_description:
            text = robot_description(self._urdf_path, inline_meshes=not local_files)
            self._robot_description[local_files] = cdr.string(text)
            self._robot_markers[local_files] = robot_markers(
                self._urdf_path, self.names.frame, not local_files, label=self.names.vehicle
            )
        ns = self.fanout.ns(step)
        markers = cdr.marker_array([m._replace(ns=ns) for m in self._robot_markers[local_files]])
        return ((self._description, ns, self._robot_description[local_files]), (self._markers, ns, markers))

    # --- producers ----------------------------------------------------------------------------

    def _publish_one(self, topic: Topic, step: int, encode: Callable[[int], bytes]) -> None:
        """One message on `topic` at `step`, `encode(ns)`, where a consumer takes it."""
        fanout = self.fanout
        if fanout.consumers:
            fanout.declare(topic)  # a topic not every run has (/joy) is announced before its first message
            ns = fanout.ns(step)
            fanout.publish(((topic, ns, encode(ns)),))

    def on_command(self, step: int, twist: Twist) -> None:
        """The command as the controller received it -> /quad_cmd_twist."""
        self._publish_one(self._twist, step, lambda ns: cdr.twist(twist[:3], twist[3:]))

    def on_state(self, state: VehicleState) -> None:
        """A state -> pose, odometry, IMU (its noisy reading where the run has one), rotor
        thrusts, /tf and, in runs with wind, /wind, all stamped at its step."""
        fanout = self.fanout
        if not fanout.consumers:
            return
        ns = state.step * NS_PER_S // fanout.physics_hz
        p, q, rates = state.position_m, state.orientation_xyzw, state.angular_velocity_body_rps
        thrusts = state.rotor_thrusts_n
        velocity = body_velocity(q, state.linear_velocity_mps)  # odometry's twist is in base_link
        imu = state.imu
        imu_rates, specific_force = (
            (rates, state.specific_force_body_mps2) if imu is None else imu
        )  # ground truth stays on pose and odometry
        pose, odom, imu_topic, thrust_topic, tf = self._state_topics
        messages = [
            (pose, ns, self._pose(ns, p, q)),
            (odom, ns, self._odometry(ns, p, q, velocity, rates)),
            (imu_topic, ns, self._imu(ns, q, imu_rates, specific_force)),
            (thrust_topic, ns, _thrusts_encoder(len(thrusts))(thrusts)),
            (tf, ns, self._tf(ns, p, q)),
        ]
        if state.wind_mps is not None:
            fanout.declare(self._wind)
            messages.append((self._wind, ns, cdr.vector3_stamped(ns, WORLD_FRAME, state.wind_mps)))
        fanout.tick(ns)  # the clock comes from states alone: a frame that arrives late never turns it back
        fanout.publish(messages)

    def on_camera_frame(self, frame: CameraFrame) -> None:
        """A rendered frame -> its CompressedImage and the matching CameraInfo, then its depth
        image and CameraInfo, the depth colour-mapped (a JPEG: the render worker's, else made
        here) and its segmentation image where the camera has them (a frame rendered before
        they were asked for has none)."""
        camera = self._cameras.get(frame.camera)
        fanout = self.fanout
        if camera is None or not fanout.consumers:
            return
        jpeg = frame.jpeg
        if jpeg is None:  # rendered before a recording asked for JPEG (it was in flight)
            if frame.rgb is None:
                return
            from quadsim.sensors.rendering import encode_jpeg

            jpeg = encode_jpeg(frame.rgb, camera.spec.jpeg_quality)
        ns = fanout.ns(frame.step)
        i = self._infos[frame.camera]
        info = cdr.camera_info(ns, camera.frame, i.height_px, i.width_px, i.distortion_model, i.d, i.k, i.r, i.p)
        topics = camera.topics
        messages = [
            (topics["image"], ns, cdr.compressed_image(ns, camera.frame, "jpeg", jpeg)),
            (topics["info"], ns, info),
        ]
        if "depth" in topics and frame.depth_pixels is not None:
            pixels = frame.depth_pixels
            messages.append((topics["depth"], ns, _image(ns, camera.frame, camera.spec.depth, pixels)))
            messages.append((topics["depth_info"], ns, info))
            if "colormap" in topics:
                colormap = frame.depth_colormap_jpeg
                if colormap is None:  # rendered before JPEG was asked for, or by no rig
                    colormap = depth_colormap_jpeg(pixels, camera.spec.depth, camera.spec.jpeg_quality)
                messages.append((topics["colormap"], ns, cdr.compressed_image(ns, camera.frame, "jpeg", colormap)))
        if "segmentation" in topics and frame.labels is not None:
            encoding = "mono8" if frame.labels.dtype == np.uint8 else "16UC1"
            messages.append((topics["segmentation"], ns, _image(ns, camera.frame, encoding, frame.labels)))
        fanout.publish(messages)

    def on_range(self, reading: Ranges) -> None:
        """A range finder's reading (its one beam) -> /quad/range."""
        if self._range is not None:
            self._publish_one(self._range, reading.step, lambda ns: self._range_message(ns, reading.ranges_m))

    def on_scan(self, scan: Ranges) -> None:
        """A LiDAR's scan -> /quad/scan (2D), or its returns as points in its frame -> /quad/points (3D)."""
        if self._scan is not None:
            self._publish_one(self._scan, scan.step, lambda ns: self._scan_message(ns, scan.ranges_m))

    def on_joy(self, step: int, axes: Sequence[float], buttons: Sequence[int]) -> None:
        """Joystick axes and buttons in the ROS `joy` convention -> /joy."""
        self._publish_one(self._joy, step, lambda ns: cdr.joy(ns, self._joy_frame, axes, buttons))

    def on_event(self, step: int, kind: str, value: str) -> None:
        """A flight event from the loop (take-off, touchdown, landed, crash, reset) -> /rosout."""
        self.note_event(step, kind, value)

    def note_event(self, step: int, kind: str, value: str) -> None:
        """An event of this vehicle (a z-mode switch, a flight event) -> /rosout, as its logger's."""
        self.fanout.note_event(step, kind, value, self.names.vehicle, self._logger)
