"""The folder tree is the architecture: each layer imports only its own layer and the layers below it.

Walks every import statement of the package (module level and inside functions) and fails on
one that reaches up: between the package's layers, and between the layers inside quadsim.apps.
The order is docs/reference/architecture.md's, bottom first."""

from __future__ import annotations

import ast
from pathlib import Path

import quadsim

PACKAGE = Path(quadsim.__file__).parent

#: bottom first; a module may import its own layer and any layer listed before it
LAYERS = [
    {"quadsim.errors", "quadsim.core", "quadsim.assets"},
    {"quadsim.vehicle"},
    {"quadsim.control", "quadsim.drivers"},
    {"quadsim.physics"},
    {"quadsim.sensors"},
    {"quadsim.sim"},
    {"quadsim.recording"},
    {"quadsim.live"},
    {"quadsim.envs"},
    {"quadsim.session"},
    {"quadsim.apps"},
]
#: the layers inside quadsim.apps, bottom first: options (and what they become) at the bottom;
#: plans and reports; the flights (headless, sweeps, windows); the bench; the commands (and the
#: pytest plugin, which shares `check`'s implementation); the command line on top
APP_LAYERS = [
    {"quadsim.apps", "quadsim.apps.options"},
    {
        "quadsim.apps.plans",
        "quadsim.apps.regression",
        "quadsim.apps.flight_quality",
        "quadsim.apps.flight_plot",
        "quadsim.apps.replay_export",
    },
    {"quadsim.apps.flying", "quadsim.apps.sweep", "quadsim.apps.window"},
    {"quadsim.apps.bench"},
    {"quadsim.apps.commands", "quadsim.apps.pytest_plugin"},
    {"quadsim.apps.cli", "quadsim.apps.launch"},
]
#: the package's front doors name the public API lazily and may point anywhere; the shipped
#: examples are user programs (package data), written against the public API
EXEMPT = {"quadsim", "quadsim.__main__"}


def exempt(module: str) -> bool:
    return module in EXEMPT or module.startswith("quadsim.assets.examples.")


def layer_of(module: str, layers: list[set[str]] = LAYERS) -> int:
    """The layer of the most specific member that holds `module` (quadsim.apps.commands.run is
    quadsim.apps.commands', not the quadsim.apps package's)."""
    held = [
        (len(m), index)
        for index, members in enumerate(layers)
        for m in members
        if module == m or module.startswith(m + ".")
    ]
    if not held:
        raise AssertionError(f"{module} belongs to no layer: add it to the layers in tests/unit/test_layers.py")
    return max(held)[1]


def in_apps(module: str) -> bool:
    return module == "quadsim.apps" or module.startswith("quadsim.apps.")


def package_modules() -> dict[str, Path]:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def imported_modules(path: Path, module: str) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(), str(path))
    is_package = path.name == "__init__.py"
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names if alias.name.startswith("quadsim")]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against this module's package
                base = module.split(".") if is_package else module.split(".")[:-1]
                base = base[: len(base) - node.level + 1]
                name = ".".join([*base, node.module] if node.module else base)
            else:
                name = node.module or ""
            if name == "quadsim":  # `from quadsim import x`: x is a module or a public name
                found += [(node.lineno, f"quadsim.{a.name}") for a in node.names]
            elif name.startswith("quadsim."):
                found.append((node.lineno, name))
    return found


def test_every_module_has_a_layer():
    for module in package_modules():
        if not exempt(module):
            layer_of(module)
            if in_apps(module):
                layer_of(module, APP_LAYERS)


def test_no_layer_imports_a_layer_above_it():
    modules = package_modules()
    upward = []
    for module, path in sorted(modules.items()):
        if exempt(module):
            continue
        own = layer_of(module)
        for lineno, target in imported_modules(path, module):
            if target in ("quadsim", "quadsim.__version__"):  # the lazy front door and the version
                continue
            if layer_of(target) > own or (
                in_apps(module) and in_apps(target) and layer_of(target, APP_LAYERS) > layer_of(module, APP_LAYERS)
            ):
                upward.append(f"{path.relative_to(PACKAGE.parent)}:{lineno}: {module} imports {target}")
    assert not upward, "imports reaching up a layer:\n" + "\n".join(upward)


def test_the_checker_sees_an_upward_import(tmp_path):
    """The walk must be able to fail: a physics module importing the recorder is caught."""
    fake = tmp_path / "fake.py"
    fake.write_text("def f():\n    from quadsim.recording.writer import McapRecorder\n")
    targets = imported_modules(fake, "quadsim.physics.fake")
    assert targets == [(2, "quadsim.recording.writer")]
    assert layer_of(targets[0][1]) > layer_of("quadsim.physics.fake")


def test_the_checker_sees_an_upward_import_inside_the_apps(tmp_path):
    """A sweep worker's module importing a command module (a CLI module) is caught."""
    fake = tmp_path / "fake.py"
    fake.write_text("from quadsim.apps.commands.run import main\n")
    (target,) = [t for _, t in imported_modules(fake, "quadsim.apps.sweep.fake")]
    assert layer_of(target, APP_LAYERS) > layer_of("quadsim.apps.sweep.fake", APP_LAYERS)
