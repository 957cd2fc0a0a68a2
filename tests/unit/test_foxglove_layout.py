"""Every vehicle visible in every Foxglove app.

Its unit tests (in-process, one part at a time); the others are in tests/e2e/test_foxglove_layout.py."""

from __future__ import annotations

import pytest

from quadsim.recording import scene


def test_a_urdfs_shapes_sizes_colours_and_meshes_become_markers(tmp_path):
    """Boxes, cylinders (along z) and spheres at their origins, coloured by a named or an inline
    material; a mesh by the URL the description gives it; a shape that cannot be read is left out."""
    (tmp_path / "arm.stl").write_bytes(b"solid arm\nendsolid arm\n")
    urdf = tmp_path / "odd.urdf"
    urdf.write_text(
        '<robot name="odd"><material name="red"><color rgba="1 0 0 1"/></material>'
        '<link name="base_link">'
        '<visual><origin xyz="1 2 3" rpy="0 0 1.5707963267948966"/><geometry><box size="0.1 0.2 0.3"/></geometry>'
        '<material name="red"/></visual>'
        '<visual><geometry><cylinder radius="0.5" length="0.1"/></geometry>'
        '<material name="x"><color rgba="0 1 0 0.5"/></material></visual>'
        '<visual><geometry><box size="0.1 nan 0.3"/></geometry></visual>'
        '<visual><geometry><capsule radius="1" length="2"/></geometry></visual>'
        "</link>"
        '<link name="rotor_1"><collision><geometry><sphere radius="0.25"/></geometry></collision></link>'
        '<link name="arm"><visual><geometry><mesh filename="arm.stl" scale="2 2 2"/></geometry></visual></link>'
        "</robot>"
    )
    box, cylinder, sphere, mesh = scene.robot_markers(urdf, lambda f: f"v/{f}")
    assert (box.type, box.scale, box.color, box.position) == (1, (0.1, 0.2, 0.3), (1.0, 0.0, 0.0, 1.0), (1.0, 2.0, 3.0))
    assert box.orientation == pytest.approx((0.0, 0.0, 2**-0.5, 2**-0.5))
    assert (cylinder.type, cylinder.scale, cylinder.color) == (3, (1.0, 1.0, 0.1), (0.0, 1.0, 0.0, 0.5))
    assert (sphere.type, sphere.scale, sphere.frame_id) == (2, (0.5,) * 3, "v/rotor_1")
    assert (mesh.type, mesh.scale, mesh.frame_id) == (10, (2.0, 2.0, 2.0), "v/arm")
    assert mesh.mesh_resource.startswith("data:model/stl;base64,") and mesh.mesh_use_embedded_materials
    assert [m.id for m in (box, cylinder, sphere, mesh)] == [0, 1, 2, 3]
    (local,) = [m for m in scene.robot_markers(urdf, inline_meshes=False) if m.type == 10]
    assert local.mesh_resource == (tmp_path / "arm.stl").as_uri()  # for RViz, which reads files


def test_a_urdf_with_endless_shapes_sends_a_bounded_message(tmp_path):
    urdf = tmp_path / "many.urdf"
    shapes = '<visual><geometry><box size="1 1 1"/></geometry></visual>' * (scene.MAX_ROBOT_MARKERS + 500)
    urdf.write_text(f'<robot name="many"><link name="base_link">{shapes}</link></robot>')
    assert len(scene.robot_markers(urdf, label="big")) == scene.MAX_ROBOT_MARKERS + 1  # and its name


def test_the_3d_panel_draws_each_vehicles_lidar():
    from quadsim.recording.foxglove_layout import foxglove_layout, vehicles_from_topics

    topics = ["/alpha/quad/odom", "/alpha/quad/points", "/alpha/robot_markers", "/bravo/quad/odom", "/bravo/quad/scan"]
    topics += ["/bravo/quad/range", "/quad/scan"]  # a range finder the 3D panel does not draw; no vehicle alone here
    vehicles = vehicles_from_topics(topics)
    assert [v.scan_topics for v in vehicles] == [("/alpha/quad/points",), ("/bravo/quad/scan",)]
    (three_dee,) = [c for key, c in foxglove_layout(vehicles)["configById"].items() if key.startswith("3D!")]
    assert {"/alpha/quad/points", "/bravo/quad/scan"} <= set(three_dee["topics"])
    points, scan = three_dee["topics"]["/alpha/quad/points"], three_dee["topics"]["/bravo/quad/scan"]
    assert points["visible"] and scan["visible"] and points["flatColor"] != scan["flatColor"]
    for drawing, field in ((points, "z"), (scan, "range")):  # a field of each, else Studio 1.48 picks one
        assert drawing["colorMode"] == "flat" and drawing["colorField"] == field and drawing["pointSize"] >= 4
