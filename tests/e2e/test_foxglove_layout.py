"""Every vehicle visible in every Foxglove app: each vehicle's model as markers in its own frames
(/robot_markers, /NAME/robot_markers), recorded and live, and the layout `quadsim layout` writes
for a recording, a fleet file's live run or one vehicle flown live; checked as ROS 2 readers
decode them, against the current Foxglove app's published layout schema (@foxglove/embed, type-
checked by TypeScript), and in a real Foxglove Studio 1.48 following docs/foxglove.md's steps."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import cv2
import pytest

from quadsim.recording.foxglove_layout import SCAN_DRAWING
from tests.e2e.test_foxglove import npm_packages
from tests.helpers import foxglove_studio
from tests.helpers.fleets import SCANS_FLEET, fleet_toml, vehicle
from tests.integration.test_cli import cli

FLEET = fleet_toml(
    vehicle("alpha", (0.0, 0.0, 0.0, 0.0), input="script:square", cameras=["front"]),
    vehicle("bravo", (0.0, 4.0, 0.0, 90.0), airframe="hexa", input="idle"),
    vehicle("charlie", (-4.0, 0.0, 0.0, 0.0), airframe="crazyflie", input="foxglove"),
)


@pytest.fixture(scope="module")
def fleet(tmp_path_factory) -> Path:
    """A fleet's recording (2 s), its fleet file beside it."""
    folder = tmp_path_factory.mktemp("fleet")
    (folder / "three.toml").write_text(FLEET.replace('"foxglove"', '"idle"'))
    (folder / "live.toml").write_text(FLEET)
    out = cli("run", "--fleet", str(folder / "three.toml"), "--duration", "2", "--out", str(folder / "three.mcap"))
    assert out.returncode == 0, out.stderr
    return folder / "three.mcap"


def _layout(*args: str, cwd: Path) -> tuple[dict, str]:
    out = cli("layout", *args, cwd=cwd)
    assert out.returncode == 0, out.stderr
    written = Path(out.stdout.split("wrote ", 1)[1].split(":", 1)[0])
    return json.loads((cwd / written).read_text()), out.stdout


def _panels(layout: dict, kind: str) -> list[dict]:
    return [config for panel, config in layout["configById"].items() if panel.split("!")[0] == kind]


def test_the_layout_of_one_vehicle_flown_live_follows_it(tmp_path):
    layout, _ = _layout(cwd=tmp_path)
    assert (tmp_path / "quadsim.layout.json").is_file()
    (three_dee,) = _panels(layout, "3D")
    assert three_dee["topics"] == {"/robot_markers": {"visible": True}, "/world/markers": {"visible": True}}
    assert three_dee["followTf"] == "base_link" and "frame:rotor_1" in three_dee["transforms"]
    assert [p["cameraTopic"] for p in _panels(layout, "ImageViewPanel")] == [
        "/quad/front_camera/image_raw/compressed",
        "/quad/floor_camera/image_raw/compressed",
    ]
    assert {t["topic"] for t in _panels(layout, "Teleop")} == {"/quad_cmd_twist"}
    layout, _ = _layout("--cameras", "none", "-o", "bare.json", cwd=tmp_path)
    assert not _panels(layout, "ImageViewPanel")


def test_layout_refuses_what_it_cannot_write_in_one_line(tmp_path, fleet):
    for args, words in (
        (("--cameras", "side"), "no camera side"),
        (("-o", "layout.txt"), "a .json file"),
        ((str(tmp_path / "none.mcap"),), "none.mcap"),
        (("-o", str(tmp_path / "no" / "such" / "x.json")), "cannot write"),
    ):
        out = cli("layout", *args, cwd=tmp_path)
        assert out.returncode == 2 and words in out.stderr and "Traceback" not in out.stderr, out.stderr
        assert len(out.stderr.strip().splitlines()) == 1


# --- the current Foxglove app's published layout schema --------------------------------------------

#: the current app's layout schema as its embedding package publishes it (src/layout.generated.ts,
#: generated from the app's JSON schema), and the compiler that checks a layout against it
SCHEMA_PACKAGES = ("@foxglove/embed@0.2.3", "typescript@5.9")
SCHEMA_CACHE = Path.home() / ".cache" / "quadsim-tests" / "foxglove-layout-schema"
#: each panel of a layout (by the type its id names) and the schema type its settings must be;
#: Studio 1.x's image panel is the current app's Image panel after the app migrates it on import
SCHEMA_TYPES = {"3D": "ThreeDeeConfig", "Teleop": "TeleopConfig", "Plot": "PlotConfig", "RosOut": "LogConfig"}


def _schema_modules() -> Path:
    return npm_packages(SCHEMA_CACHE, SCHEMA_PACKAGES, "type-checking a layout against @foxglove/embed's schema")


def _type_check(layout: dict, folder: Path) -> subprocess.CompletedProcess:
    """tsc over a module that declares each panel's settings as its schema type (an object
    literal: a key the schema does not have is an error too)."""
    modules = _schema_modules()
    lines = [f'import type {{ {", ".join(sorted(SCHEMA_TYPES.values()))} }} from "@foxglove/embed";']
    drawing = {key for keys in SCAN_DRAWING.values() for key in keys}
    for i, (panel, config) in enumerate(layout["configById"].items()):
        kind = SCHEMA_TYPES.get(panel.split("!")[0])
        if kind is not None:  # a title is the panel's, beside its settings in the schema
            settings = {k: v for k, v in config.items() if k != "foxglovePanelTitle"}
            if "topics" in settings:  # the scans' drawing, which the schema types by no layer's settings
                topics = settings["topics"].items()
                settings["topics"] = {t: {k: v for k, v in c.items() if k not in drawing} for t, c in topics}
            assert isinstance(config.get("foxglovePanelTitle", ""), str)
            lines.append(f"export const panel{i}: {kind} = {json.dumps(settings)};")
    (folder / "layout.ts").write_text("\n".join(lines) + "\n")
    (folder / "node_modules").unlink(missing_ok=True)
    (folder / "node_modules").symlink_to(modules)
    tsc = modules / "typescript" / "bin" / "tsc"
    args = ["--noEmit", "--strict", "--skipLibCheck", "--module", "nodenext", "--moduleResolution", "nodenext"]
    return subprocess.run(["node", str(tsc), *args, "layout.ts"], capture_output=True, text=True, cwd=folder)


def test_every_layout_matches_the_current_foxglove_apps_layout_schema(fleet, tmp_path):
    layouts = [_layout(str(fleet), "-o", str(tmp_path / "rec.json"), cwd=tmp_path)[0]]
    layouts.append(_layout(str(fleet.parent / "live.toml"), "-o", str(tmp_path / "live.json"), cwd=tmp_path)[0])
    layouts.append(_layout("-o", str(tmp_path / "one.json"), cwd=tmp_path)[0])
    for layout in layouts:
        done = _type_check(layout, tmp_path)
        assert done.returncode == 0, done.stdout + done.stderr
    broken = json.loads(json.dumps(layouts[0]))
    broken["configById"]["3D!quadsim"]["scene"]["transforms"]["axisScale"] = 0.3  # Studio 1.48's name for it
    done = _type_check(broken, tmp_path)
    assert done.returncode != 0 and "axisScale" in done.stdout  # it can fail


# --- a real Foxglove Studio 1.48 ------------------------------------------------------------------


@pytest.mark.slow
def test_studio_148_draws_every_vehicle_of_a_fleet_after_importing_its_layout(tmp_path):
    """docs/foxglove.md's steps in Studio 1.48: open the recording, import the layout quadsim
    wrote for it; the 3D panel draws each vehicle's model (a recording without /NAME/robot_markers
    shows none: Studio 1.48 cannot draw /NAME/robot_description)."""
    try:
        foxglove_studio.studio()
    except foxglove_studio.NoStudio as exc:
        pytest.skip(str(exc))
    (tmp_path / "plain.toml").write_text("[floor]\nsize_m = 40.0\n")
    two = FLEET.split('[[vehicle]]\nname = "charlie"')[0].replace('cameras = ["front"]', "")
    (tmp_path / "two.toml").write_text(two)
    fleet = tmp_path / "two.mcap"
    plain = ("--world", str(tmp_path / "plain.toml"), "--duration", "2", "--out", str(fleet))
    out = cli("run", "--fleet", str(tmp_path / "two.toml"), *plain)
    assert out.returncode == 0, out.stderr
    layout, _ = _layout(str(fleet), cwd=tmp_path)
    layout["configById"]["3D!quadsim"]["transforms"]["frame:world"] = {"visible": False}  # its axes are red and blue
    (tmp_path / "two.layout.json").write_text(json.dumps(layout))
    panel = (60, 40, 1000, 900)  # the 3D panel, left of the plot and the log

    def both_drawn(shot: Path) -> bool:
        return (
            foxglove_studio.vehicles_drawn(shot, panel) == 2 and foxglove_studio.vehicle_names_drawn(shot, panel) == 2
        )

    with foxglove_studio.served({"two.mcap": fleet, "two.layout.json": tmp_path / "two.layout.json"}) as url:
        steps = ["open-file=/data/two.mcap", "import-layout=/data/two.layout.json", "sidebar=layouts"]
        shot = foxglove_studio.shot_showing(url, tmp_path / "steps.log", tmp_path / "shots", both_drawn, *steps)
    assert both_drawn(shot)  # (shot_showing raises when no screenshot shows them)


@pytest.mark.slow
def test_studio_148_draws_both_scans_around_the_vehicles_after_importing_the_layout(tmp_path):
    """The same steps on a fleet of two with a 2D and a 3D LiDAR before the red tower: the 3D panel
    draws the 3D scan's returns in cyan and the 2D scan's in yellow (the layout's SCAN_DRAWING) on
    the pillar and the tower's face (docs/img/foxglove_scans.png is such a picture)."""
    try:
        foxglove_studio.studio()
    except foxglove_studio.NoStudio as exc:
        pytest.skip(str(exc))
    (tmp_path / "scans.toml").write_text(SCANS_FLEET)
    scans = tmp_path / "scans.mcap"
    out = cli("run", "--fleet", str(tmp_path / "scans.toml"), "--duration", "3", "--out", str(scans))
    assert out.returncode == 0, out.stderr
    _layout(str(scans), cwd=tmp_path)

    def scan_pixels(shot: Path) -> tuple[int, int]:
        image = cv2.imread(str(shot))[40:900, 60:1000].astype(int)  # the 3D panel
        b, g, r = image[:, :, 0], image[:, :, 1], image[:, :, 2]
        cyan, yellow = (b > 220) & (g > 220) & (r < 60), (r > 220) & (g > 220) & (b < 60)  # Studio's own: ~0 of each
        return int(cyan.sum()), int(yellow.sum())

    def both_drawn(shot: Path) -> bool:
        cyan, yellow = scan_pixels(shot)
        return cyan > 500 and yellow > 20

    with foxglove_studio.served({"scans.mcap": scans, "scans.layout.json": tmp_path / "scans.layout.json"}) as url:
        steps = ["open-file=/data/scans.mcap", "import-layout=/data/scans.layout.json", "sidebar=layouts", "seek=0.9"]
        shot = foxglove_studio.shot_showing(url, tmp_path / "steps.log", tmp_path / "shots", both_drawn, *steps)
    assert both_drawn(shot), scan_pixels(shot)  # (shot_showing raises when no screenshot shows them)
