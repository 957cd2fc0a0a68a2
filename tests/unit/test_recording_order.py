"""A recording is in log-time order, camera frames included (they are rendered elsewhere and
come late), and one started mid-run begins when it began.

Its unit tests (in-process, one part at a time); the others are in tests/e2e/test_recording_order.py."""

from __future__ import annotations

from quadsim import SimConfig, Simulator


def test_a_frame_later_than_the_hold_is_left_out_not_written_out_of_order():
    """In the window frames come when they are ready; the recorder holds the rest back for them
    half a second of simulated time at most, then writes; a frame that comes later still is left
    out (it would break the file's log-time order) and counted."""
    from quadsim.recording.contract import POSE, Topic
    from quadsim.recording.writer import MAX_FRAME_WAIT_NS, _LogTimeOrder

    image = Topic("/quad/front_camera/image_raw/compressed", "sensor_msgs/msg/CompressedImage")
    order = _LogTimeOrder({image.name: ""}, start_ns=0)
    written = []
    for i in range(1, 61):  # a second of states at 60 Hz, no frame yet
        written += order.push([(POSE, i * 1_000_000_000 // 60, b"")])
    assert written and written[-1][1] <= 1_000_000_000 - MAX_FRAME_WAIT_NS  # held half a second, no more
    written += order.push([(image, 100_000_000, b"late"), (image, 900_000_000, b"in time")])
    written += order.drain()
    times = [ns for _, ns, _ in written]
    assert times == sorted(times) and order.late == 1
    assert [data for topic, _, data in written if topic is image] == [b"in time"]


def test_a_fleets_vehicles_each_deliver_frames_at_their_own_pace_and_none_is_left_out():
    """In the window, alpha's pipeline handed its frames on promptly and delta's a few frames
    later: alpha's let everything up to them be written, so delta's came 'late' and nearly all were
    left out of the file (7 of about 780 in 26 s). Each vehicle's frames now hold the rest."""
    from quadsim.recording.contract import POSE, Topic
    from quadsim.recording.writer import _LogTimeOrder

    alpha = Topic("/alpha/quad/front_camera/image_raw/compressed", "sensor_msgs/msg/CompressedImage")
    delta = Topic("/delta/quad/front_camera/image_raw/compressed", "sensor_msgs/msg/CompressedImage")
    order = _LogTimeOrder({alpha.name: "alpha", delta.name: "delta"}, start_ns=0)
    frame_ns = [k * 1_000_000_000 // 30 for k in range(1, 31)]
    written = []
    for i in range(1, 61):  # a second at 60 Hz: alpha's frame of a moment comes with its state,
        now = i * 1_000_000_000 // 60  # delta's frames six frames (0.2 s) later
        came = [(POSE, now, b"")]
        came += [(alpha, ns, b"a") for ns in frame_ns if now - 1_000_000_000 // 60 < ns <= now]
        came += [(delta, ns, b"d") for ns in frame_ns if now - 1_000_000_000 // 60 < ns + 200_000_000 <= now]
        written += order.push(came)
    written += order.drain()
    times = [ns for _, ns, _ in written]
    assert times == sorted(times) and order.late == 0
    delta_written = [ns for topic, ns, _ in written if topic is delta]
    assert delta_written == [ns for ns in frame_ns if ns + 200_000_000 <= 1_000_000_000]  # every one that came


def test_a_late_frames_depth_and_segmentation_are_left_out_with_it():
    """A camera's depth (and its colour map) and segmentation images are its frame's messages: held and left out as
    the frame is, never written out of log-time order."""
    from quadsim.recording.contract import POSE, frame_topics
    from quadsim.recording.writer import _camera_topics, _LogTimeOrder
    from quadsim.sensors.camera import CameraSpec

    spec = CameraSpec("front", "front_camera_link", depth="16UC1", segmentation=True, depth_colormap=True)
    with Simulator(SimConfig()) as sim:
        described = sim.description().with_outputs((spec,), 0)
    topics = tuple(frame_topics(spec).values())
    assert set(_camera_topics(described)) == {t.name for t in topics} and len(topics) == 6
    order = _LogTimeOrder(_camera_topics(described), start_ns=0)
    written = []
    for i in range(1, 61):
        written += order.push([(POSE, i * 1_000_000_000 // 60, b"")])
    written += order.push([(topic, 100_000_000, b"late") for topic in topics])
    written += order.drain()
    times = [ns for _, ns, _ in written]
    assert times == sorted(times) and order.late == 6 and all(data == b"" for _, _, data in written)


def test_a_slow_run_closes_a_chunk_every_wall_second(tmp_path):
    """A camera run on a busy machine takes several wall seconds per simulated second: the file
    gets a complete chunk once a wall second has passed, not only at each simulated second, so a
    run killed in its first simulated second keeps what it flew (it kept nothing)."""
    import shutil

    from quadsim.recording.contract import TWIST
    from quadsim.recording.mcap_scan import McapFile
    from quadsim.recording.writer import McapRecorder

    def on_disk() -> int:
        """The messages in complete chunks of the file as it is now (what a kill -9 leaves)."""
        shutil.copyfile(path, tmp_path / "now.mcap")
        with McapFile(tmp_path / "now.mcap") as found:
            return found.message_count

    wall_s = [0.0]
    path = tmp_path / "slow.mcap"
    with Simulator(SimConfig()) as sim:
        recorder = McapRecorder(path, sim.description(), clock=lambda: wall_s[0])
        recorder.add_topic(TWIST)
        recorder.on_messages([(TWIST, 100_000_000, b"\0" * 8)])
        assert on_disk() == 0  # 0.1 s of simulated time, no wall time: still in the open chunk
        wall_s[0] = 0.9
        recorder.on_messages([(TWIST, 200_000_000, b"\0" * 8)])
        assert on_disk() == 0
        wall_s[0] = 1.05  # a wall second since the recorder opened
        recorder.on_messages([(TWIST, 300_000_000, b"\0" * 8)])
        assert on_disk() == 3
        recorder.on_messages([(TWIST, 1_000_000_000, b"\0" * 8)])  # a simulated second: closed as before
        assert on_disk() == 4
        recorder.close()
