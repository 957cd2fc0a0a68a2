"""The documentation: the command-line reference is what `--help` prints, every block marked
runnable runs, the pictures show something, and the README stays a front door."""

from __future__ import annotations

import re

import cv2
import pytest

from tests.helpers import ROOT

DOCS = ROOT / "docs"
PAGES = sorted(DOCS.rglob("*.md"))
RUNNABLE = re.compile(r"<!-- runnable -->\n```sh\n(.*?)\n```", re.S)


def _runnable_commands() -> list[tuple[str, str]]:
    found = []
    for page in [ROOT / "README.md", *PAGES]:
        for block in RUNNABLE.findall(page.read_text()):
            found += [(page.name, line.split("  #")[0].strip()) for line in block.splitlines() if line.strip()]
    return found


def test_there_are_runnable_blocks():
    assert len(_runnable_commands()) >= 4


def test_the_pictures_show_the_scene():
    """docs/img/cameras.png (tools/make_doc_pictures.py): the two camera views, the red tower in
    the front one; not a blank or black image."""
    image = cv2.imread(str(DOCS / "img" / "cameras.png"))
    assert image is not None and image.shape[1] > 2 * image.shape[0]
    assert image.std() > 20.0
    front = image[:, : image.shape[1] // 2].astype(int)
    red = (front[:, :, 2] > 120) & (front[:, :, 2] > 2 * front[:, :, 1]) & (front[:, :, 2] > 2 * front[:, :, 0])
    assert red.mean() > 0.03


def test_the_window_picture_shows_the_window():
    """docs/img/window.png: the real replay window grabbed under Xvfb: the front camera's sky and
    the red tower on the left, the dark map on the right, a HUD with text; not blank."""
    image = cv2.imread(str(DOCS / "img" / "window.png"))
    assert image is not None and image.shape[:2] == (800, 1280) and image.std() > 30.0
    front, side = image[120:700, :880].astype(int), image[300:780, 900:].astype(int)
    red = (front[:, :, 2] > 120) & (front[:, :, 2] > 2 * front[:, :, 1]) & (front[:, :, 2] > 2 * front[:, :, 0])
    sky = (front[:, :, 0] > 180) & (front[:, :, 0] > front[:, :, 2] + 20)
    assert red.mean() > 0.05 and sky.mean() > 0.05
    assert side.mean() < 80  # the map is dark
    hud = image[5:110, 5:760]
    assert (hud > 200).all(axis=2).mean() > 0.01  # white text on the HUD


def test_the_fleet_picture_shows_every_vehicles_track():
    """docs/img/fleet.png (replay --plot of the example fleet): the Crazyflie's figure eight in red
    and the quad's square in grey on the map, commands against the flight on the right."""
    image = cv2.imread(str(DOCS / "img" / "fleet.png"))
    assert image is not None and image.shape[1] > image.shape[0]
    track = image[:, : image.shape[1] * 2 // 5].astype(int)
    b, g, r = track[:, :, 0], track[:, :, 1], track[:, :, 2]
    red = (r > 180) & (g < 90) & (b < 90)
    grey = (abs(r - 140) < 12) & (abs(g - 140) < 12) & (abs(b - 140) < 12)
    assert red.sum() > 800 and grey.sum() > 500, (red.sum(), grey.sum())  # a landmark alone is ~100 px


@pytest.mark.parametrize("picture", ["foxglove_fleet.png", "foxglove_live.png"])
def test_the_foxglove_pictures_show_every_vehicle_of_the_example_fleet(picture):
    """docs/img/foxglove_*.png: Foxglove Studio 1.48 after docs/foxglove.md's steps: the four
    vehicles' names over their models, the rotors of at least the three larger ones (the
    Crazyflie's are a few pixels)."""
    from tests.helpers.foxglove_studio import vehicle_names_drawn, vehicles_drawn

    panel = (40, 25, 755, 690)  # the 3D panel of a 1200 x 750 picture
    assert vehicle_names_drawn(DOCS / "img" / picture, panel) == 4
    assert vehicles_drawn(DOCS / "img" / picture, panel) >= 3


def test_the_foxglove_depth_picture_shows_the_depth_of_what_the_camera_sees():
    """docs/img/foxglove_depth.png (docs/recordings.md): Foxglove Studio 1.48's image panels on a
    recording with depth and segmentation: the front camera's blue sky; in its depth beside it
    (16UC1, grey by value) the sky black (no depth, 0) over a floor lightening toward the horizon;
    the label image dark (ids 0 to 7 of 255)."""
    image = cv2.imread(str(DOCS / "img" / "foxglove_depth.png")).astype(int)
    third = image.shape[1] // 3
    rgb, depth, labels = (
        image[40:320, 10 : third - 10],
        image[40:320, third + 10 : 2 * third - 10],
        image[40:320, 2 * third + 10 :],
    )
    sky = rgb[10:60]
    assert (sky[:, :, 0] > sky[:, :, 2] + 40).mean() > 0.9  # blue (BGR) above the horizon
    assert depth[10:60].max() < 10  # no depth above the horizon
    floor = [depth[row, :200].mean() for row in (160, 200, 240, 279)]  # away from the pillar, down
    assert floor == sorted(floor, reverse=True) and floor[0] > floor[-1] + 60  # farther is lighter
    assert labels.max() < 20


def test_the_foxglove_scans_picture_shows_both_scans_on_the_tower_and_the_depth_in_turbo():
    """docs/img/foxglove_scans.png (docs/recordings.md): Foxglove Studio 1.48 with quadsim's layout
    on a fleet of two before the red tower: in the 3D panel bravo's 3D scan in cyan on the green
    pillar, the floor and the tower's face, alpha's 2D ring in yellow on both; beside it alpha's
    depth colour-mapped: the sky black, the floor green below and cyan farther."""
    image = cv2.imread(str(DOCS / "img" / "foxglove_scans.png")).astype(int)  # BGR
    three_dee, depth = image[:, :740], image[180:334, 872:1072]
    b, g, r = three_dee[:, :, 0], three_dee[:, :, 1], three_dee[:, :, 2]
    cyan, yellow = (b > 180) & (g > 180) & (r < 120), (r > 220) & (g > 220) & (b < 60)
    assert cyan[:, :370].sum() > 300 and cyan[:, 370:].sum() > 300  # the pillar's side, the tower's
    assert cyan[60:300, 640:].sum() > 100 and yellow[60:300, 640:].sum() > 15  # on the tower's face
    assert yellow[:, :370].sum() > 10  # the ring on the pillar too
    assert depth[:70, :40].max() < 20 and depth[:70, 120:].max() < 20  # no depth in the sky, beside the pillar
    near, far = depth[150, 30], depth[100, 30]  # the floor below, the floor farther
    assert near[1] > 200 and near[1] > near[0] + 50 and near[1] > near[2] + 50  # green
    assert far[0] > 180 and far[1] > 180 and far[2] < 100  # cyan


def test_the_foxglove_colour_mapped_depth_picture_shows_near_and_far_in_turbo():
    """docs/img/foxglove_depth_colormap.png (docs/foxglove.md): Foxglove Studio 1.48 with quadsim's
    layout on a recording with --camera-depth-colormap front: the camera's blue sky; under it
    its depth colour-mapped, the sky black (no depth), the floor green below the camera and blue
    toward the horizon (farther), the green pillar another colour than the floor beside it."""
    image = cv2.imread(str(DOCS / "img" / "foxglove_depth_colormap.png")).astype(int)  # BGR
    camera, depth = image[32:228, 215:425], image[262:460, 165:425]
    sky = camera[10:40, :150]
    assert (sky[:, :, 0] > sky[:, :, 2] + 40).mean() > 0.9  # blue
    assert depth[5:70].max() < 20  # no depth above the horizon: black
    near, far = depth[190, 30], depth[100, 30]  # the floor below, the floor toward the horizon
    assert near[1] > 200 and near[1] > near[0] + 50 and near[1] > near[2] + 50  # green
    assert far[0] > 200 and far[0] > far[2] + 100  # blue
    pillar, floor = depth[130, 230], depth[130, 30]
    assert pillar[1] > 200 and abs(pillar - floor).sum() > 100


def test_the_fleet_window_picture_shows_the_other_vehicles():
    """docs/img/fleet_window.png: the real fly --fleet window: the red tower in the front camera,
    the other vehicles in blue on the dark map, the HUD's text."""
    image = cv2.imread(str(DOCS / "img" / "fleet_window.png"))
    assert image is not None and image.shape[:2] == (800, 1280) and image.std() > 30.0
    front, side = image[120:700, :880].astype(int), image[300:780, 900:].astype(int)
    red = (front[:, :, 2] > 120) & (front[:, :, 2] > 2 * front[:, :, 1]) & (front[:, :, 2] > 2 * front[:, :, 0])
    assert red.mean() > 0.03
    blue = (abs(side[:, :, 0] - 255) < 30) & (abs(side[:, :, 1] - 170) < 30) & (abs(side[:, :, 2] - 110) < 30)
    assert blue.sum() > 30 and side.mean() < 80  # the others drawn on the dark map
    assert (image[5:110, 5:760] > 200).all(axis=2).mean() > 0.01  # white text on the HUD


def test_the_readme_is_a_front_door():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) <= 200
    for page in re.findall(r"\]\((docs/[^)#]+)\)", readme):
        assert (ROOT / page).is_file(), page
    for needed in ("make fly", "make test", "Foxglove", "ROS 2", "check"):
        assert needed in readme


#: how a clone runs a program: its own environment's python (what `make fly` sets up)
BARE_PYTHON = re.compile(r"(?<![\w/.-])python3? (main\.py|examples/)")
#: pages whose text is rewritten elsewhere for now (the architecture page's layout tree)


def test_the_docs_spell_a_clones_commands_one_way():
    """A clone runs `.venv/bin/python main.py` (a bare `python main.py` is the system's Python,
    which lacks the dependencies); installed, `quadsim`. The README, every page and the shipped
    examples say it so."""
    texts = [ROOT / "README.md", *PAGES, *sorted((ROOT / "quadsim" / "assets" / "examples").iterdir())]
    found = [
        f"{path.relative_to(ROOT)}: {line.strip()}"
        for path in texts
        if path.suffix in (".md", ".py", ".toml")
        for line in path.read_text().splitlines()
        if BARE_PYTHON.search(line)
    ]
    assert not found, "\n".join(found)


def test_the_docs_name_the_version_they_describe():
    """The docs, the changelog's newest heading and `quadsim.__version__` (what the wheel and
    `--version` say) name one version: a user can tell whether the pages describe theirs."""
    import quadsim

    version = quadsim.__version__
    assert f"These pages describe quadsim **{version}**" in (DOCS / "index.md").read_text()
    changelog = (ROOT / "CHANGELOG.md").read_text()
    newest = next(line for line in changelog.splitlines() if line.startswith("## ["))
    assert newest == f"## [Unreleased] - {version}"
    for page in [ROOT / "README.md", *PAGES]:
        assert "(unreleased)" not in page.read_text().lower(), page  # a version the docs cannot name


def test_code_blocks_wrap_rather_than_cut_off():
    """At 1280 px a code block holds about 66 characters: wider lines (a command's comment, a
    usage line argparse cannot break) wrap, through the site's stylesheet, instead of running
    off the page."""
    import yaml

    config = yaml.load((ROOT / "mkdocs.yml").read_text(), Loader=yaml.BaseLoader)
    (sheet,) = config["extra_css"]
    css = (DOCS / sheet).read_text()
    rule = re.search(r"\.md-typeset pre > code \{([^}]*)\}", css)
    assert rule is not None and "white-space: pre-wrap" in rule[1]


def test_what_the_script_format_says_of_height_mode_is_how_it_flies():
    """The page says `linear.z=0` in height mode holds 2 m (it did not say so), `linear.z=1` 3 m;
    a script that says so flies there."""
    from quadsim import SimConfig, Simulator, StateLog, ZMode
    from quadsim.drivers.scripted import ScriptedDriver, parse_script

    page = " ".join((DOCS / "reference" / "script-format.md").read_text().split())
    assert "so `linear.z=0` holds 2 m, `linear.z=1` 3 m" in page
    for z, metres in ((0.0, 2.0), (1.0, 3.0)):
        script = parse_script(f"z_mode height\n8.0 linear.z={z}\n", "page")
        with Simulator(SimConfig(z_mode=ZMode.HEIGHT), ScriptedDriver(script)) as sim:
            log = StateLog()
            sim.add_sink(log)
            sim.run_for(script.duration_s)
        assert abs(log.states[-1].position_m[2] - metres) < 0.05, (z, log.states[-1].position_m)


def test_getting_started_ends_with_where_to_go_next():
    """It ended after the first recording: now the window's keys, what the cameras cost, and where
    to go, every key named being one the teleop page's table has."""
    page = (DOCS / "getting-started.md").read_text()
    steps = page.split("## Next steps", 1)[1]
    assert "--cameras none" in steps and "Esc" in steps and "(teleop.md)" in steps
    keys = (DOCS / "teleop.md").read_text().split("| keys (default layout) |", 1)[1].split("\n\n", 1)[0]
    for named in ("W / S", "A / D", "Space", "Tab", "Esc", "F1"):
        assert named in keys


def test_the_docs_record_your_flights_into_a_folder_of_your_own():
    """In a clone, tests/recordings/ is the project's own suite: the docs wrote new flights there."""
    for page in [ROOT / "README.md", *PAGES]:
        assert "--out tests/recordings" not in page.read_text(), page


def _tree_entries() -> tuple[set[str], set[tuple[str, str]]]:
    """The folders and the (folder, file) pairs the architecture page's tree names: a folder is a
    `name/` entry; a file is any `name.py` on the line of an entry (and on the description lines
    under it), in that entry's folder (or the folder it opens)."""
    page = (DOCS / "reference" / "architecture.md").read_text()
    tree = page.split("## The tree\n\n```\n", 1)[1].split("\n```", 1)[0]
    folders: set[str] = set()
    files: set[tuple[str, str]] = set()
    stack: list[tuple[int, str]] = []  # (indent, folder path) of the folders open above
    line_folder = ""
    for line in tree.splitlines():
        indent = len(line) - len(line.lstrip())
        first = line.split()[0] if line.strip() else ""
        if indent < 25:  # an entry, not a description carried over
            while stack and stack[-1][0] >= indent:
                stack.pop()
            parent = stack[-1][1] if stack else ""
            if first.endswith("/"):
                line_folder = f"{parent}{first}"
                folders.add(line_folder)
                stack.append((indent, line_folder))
            else:
                line_folder = parent
        files.update((line_folder, name) for name in re.findall(r"\b(\w+\.py)\b", line))
    return folders, files


def test_the_architecture_page_names_every_module():
    """Every module of the package is in the tree of docs/reference/architecture.md, in its folder
    (a package by its folder), so the page cannot fall behind the code."""
    folders, files = _tree_entries()
    missing = []
    for path in sorted((ROOT / "quadsim").rglob("*.py")):
        relative = path.relative_to(ROOT)
        folder = "".join(f"{part}/" for part in relative.parts[:-1])
        if path.name == "__init__.py" and folder != "quadsim/":
            if folder not in folders:
                missing.append(folder)
        elif (folder, path.name) not in files:
            missing.append(str(relative))
    assert not missing, "modules missing from docs/reference/architecture.md's tree: " + ", ".join(missing)


def test_the_tree_check_sees_a_missing_module():
    folders, files = _tree_entries()
    assert "quadsim/sim/" in folders and ("quadsim/sim/", "drone.py") in files
    assert ("quadsim/apps/sweep/", "table.py") in files  # named on a description line under its folder
    assert ("quadsim/sim/", "nothing_here.py") not in files


#: a path of the repository's as the code cites one (quadsim/sim/loop.py, apps/commands/check.py,
#: tests/integration/test_clear_flight.py), or a document at its top (CONTRIBUTING.md)
_CITED = re.compile(r"(?<![\w./-])((?:[\w-]+/)+[\w.-]+\.(?:py|md|toml|mcap|urdf)|[A-Z]+\.md)\b")
_OWN_FOLDERS = {
    "quadsim",
    "tests",
    "docs",
    "examples",
    "assets",
    "tools",
    *(p.name for p in (ROOT / "quadsim").iterdir()),
}
_OTHER_REPOSITORY = re.compile(r"[\w-]+/[\w.-]+ $")  # "foxglove/ws-protocol docs/spec.md": theirs


def _dangling(path, text: str) -> list[str]:
    """The repository paths `text` (the file at `path`) cites that are not there: relative to the
    clone, the package, the tests or the file's own folder. Paths under folders of the user's
    (my_flights/...) and another repository's are not the repository's."""
    missing = []
    for match in _CITED.finditer(text):
        cited = match.group(1)
        if "/" in cited and cited.split("/", 1)[0] not in _OWN_FOLDERS:
            continue
        if _OTHER_REPOSITORY.search(text[max(0, match.start() - 60) : match.start()]):
            continue
        if not any((base / cited).exists() for base in (ROOT, ROOT / "quadsim", ROOT / "tests", path.parent)):
            missing.append(cited)
    return missing


def test_the_code_cites_no_file_that_is_not_in_the_repository():
    """Docstrings and comments send a reader to files that exist (a module moved, a document not
    in the repository: the reference is mended with it)."""
    sources = sorted([ROOT / "main.py", *(ROOT / "quadsim").rglob("*.py"), *(ROOT / "tests").rglob("*.py")])
    found = {str(p.relative_to(ROOT)): _dangling(p, p.read_text()) for p in sources}
    assert not {k: v for k, v in found.items() if v}


def test_the_citation_check_sees_a_missing_file():
    here = ROOT / "quadsim" / "apps" / "pytest_plugin.py"
    # (the missing names in two pieces, so that this file does not cite them itself)
    missing = ["apps/" + "check.py", "STYLE" + ".md"]
    assert _dangling(here, f"the work is check's own ({missing[0]}), see {missing[1]}") == missing
    assert _dangling(here, "(apps/commands/check.py; CONTRIBUTING.md; sim/loop.py)") == []
    assert _dangling(here, "from the spec (foxglove/ws-protocol docs/spec.md) into my_flights/a.mcap") == []
