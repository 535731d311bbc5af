"""Capabilities, not classes: outside their own folder, no module asks whether a sensor, a
sensor config or a ground is of some class (``isinstance``, ``type(...) is``); callers use
the protocol members (``Sensor.describe``/``top_down``, ``SensorConfig.dict_observation``/
``problems``/``camera_pixels``, ``EpisodeGround.rescalable``/``carries_pictures``)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "tinyrace"


def _classes(paths: list[Path]) -> set[str]:
    return {
        node.name
        for path in paths
        for node in ast.walk(ast.parse(path.read_text()))
        if isinstance(node, ast.ClassDef)
    }


# each family of classes, and the folder that may tell its members apart
FAMILIES = {
    "sensors": (_classes(sorted((PACKAGE / "sensors").rglob("*.py"))), PACKAGE / "sensors"),
    "grounds": (_classes(sorted((PACKAGE / "ground").rglob("*.py"))), PACKAGE / "ground"),
    "sensor configs": (_classes([PACKAGE / "config" / "sensors.py"]), PACKAGE / "config"),
}


def _names(node: ast.expr) -> list[str]:
    """The class names an isinstance's second argument gives."""
    if isinstance(node, ast.Tuple):
        return [name for element in node.elts for name in _names(element)]
    if isinstance(node, ast.Name):
        return [node.id]
    if isinstance(node, ast.Attribute):
        return [node.attr]
    return []


def _class_checks(path: Path) -> list[tuple[int, str]]:
    """(line, class name) of each isinstance/issubclass on a class named in ``path``."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in ("isinstance", "issubclass")
            and len(node.args) == 2
        ):
            found += [(node.lineno, name) for name in _names(node.args[1])]
    return found


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_no_class_dispatch_outside_the_familys_folder(family: str) -> None:
    classes, home = FAMILIES[family]
    classes -= {"Labelled"}  # a capability protocol (class labels), not a class of sensor
    found = [
        f"{path.relative_to(PACKAGE.parent)}:{line} isinstance on {name}"
        for path in sorted(PACKAGE.rglob("*.py"))
        if not path.is_relative_to(home)
        for line, name in _class_checks(path)
        if name in classes
    ]
    assert found == []


def test_the_scan_sees_a_class_check() -> None:
    """The scan finds the checks it looks for (the sensors' own view does dispatch)."""
    classes, _ = FAMILIES["sensors"]
    checks = _class_checks(PACKAGE / "sensors" / "view.py")
    assert any(name in classes for _, name in checks)
