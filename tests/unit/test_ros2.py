"""quadsim on a real ROS 2 graph.

Its unit tests (in-process, one part at a time); the others are in tests/e2e/test_ros2.py."""

from __future__ import annotations

import pytest


def test_every_configuration_matches_fast_dds_endpoints_by_type_name(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fast DDS 3's type information would unmatch every type with an array or a sequence (see
    ros2.py); whatever the discovery range, Cyclone is told to ignore eProsima's, and a
    CYCLONEDDS_URI the user set comes last, so it wins."""
    from quadsim.live import ros2
    from quadsim.live.ros2 import cyclone_configs

    ignore = "<IgnoreTypeInformation>1.15</IgnoreTypeInformation>"
    monkeypatch.setattr(ros2, "_network_is_up", lambda: False)  # only the loopback interface: Cyclone's default
    assert cyclone_configs({}) == [ros2._COMPATIBILITY_CONFIG.format(vendors="1.15")]
    monkeypatch.setattr(ros2, "_network_is_up", lambda: True)
    subnet = cyclone_configs({})
    assert all(ignore in config for config in subnet)
    assert '<NetworkInterface address="127.0.0.1"/>' in subnet[0] and '<Peer address="127.0.0.1"/>' in subnet[0]
    (local,) = cyclone_configs({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    assert ignore in local and "<AllowMulticast>false</AllowMulticast>" in local
    (own,) = cyclone_configs({"CYCLONEDDS_URI": "file:///etc/mine.xml"})
    assert own.startswith("<CycloneDDS>") and ignore in own and own.endswith(",file:///etc/mine.xml")
