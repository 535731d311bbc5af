"""The package's layers, read from the source: no import cycle, no module that imports both
pymunk and cv2, and no import that runs up the layers (docs/ARCHITECTURE.md draws them).

Every import counts, also those inside functions; only ``if TYPE_CHECKING:`` blocks are
left out (they never run).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "tinyrace"

# Bottom to top; a module may import from its own layer and the layers below it. The top
# layers are in the order docs/ARCHITECTURE.md draws (checked below): what users run is
# ordered too, not one flat layer.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("errors", "examples", "actions", "kernels", "cache"),
    ("config",),
    ("tracks",),
    ("cars",),
    ("world",),
    ("ground",),
    ("sensors",),
    ("render",),
    ("rewards",),
    ("episodes",),
    ("env_checks",),
    ("env", "carracing"),
    ("drivers",),
    ("__init__",),
    ("race",),
    ("vector",),
    ("experiment",),
    ("validate",),
    ("play",),
    ("train", "rllib", "sb3", "flat_observations"),
    ("cli", "run_command", "__main__"),
)


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imports(tree: ast.AST, module: str, is_package: bool) -> set[str]:
    """Every module named by an import statement that can run (``module:name`` for from-imports)."""
    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = module.split(".")
                anchor = anchor if is_package else anchor[:-1]
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, base]) if base else ".".join(anchor)
            # ``from package import submodule`` needs the submodule (and the package only
            # as its parent); ``from module import name`` needs the module
            found.update(f"{base}:{alias.name}" for alias in node.names)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return found


def _graph() -> dict[str, set[str]]:
    """tinyrace module -> the tinyrace modules it imports; plus '+pymunk', '+cv2', '+numba'."""
    sources = {
        _module_name(p): (p, ast.parse(p.read_text())) for p in sorted(PACKAGE.rglob("*.py"))
    }
    graph: dict[str, set[str]] = {}
    for name, (path, tree) in sources.items():
        targets = set()
        for imported in _imports(tree, name, path.name == "__init__.py"):
            base, _, member = imported.partition(":")
            imported = f"{base}.{member}" if f"{base}.{member}" in sources else base
            root = imported.split(".")[0]
            if root in ("pymunk", "cv2", "numba"):
                targets.add(f"+{root}")
            elif imported in sources and imported != name:
                targets.add(imported)
        graph[name] = targets
    return graph


GRAPH = _graph()


def _layer(module: str) -> int:
    parts = module.split(".")
    top = parts[1] if len(parts) > 1 else "__init__"
    for index, names in enumerate(LAYERS):
        if top in names:
            return index
    raise AssertionError(f"{module} is in no layer: add {top!r} to LAYERS (and the docs)")


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of ``graph`` as a path, or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for target in sorted(graph.get(node, ())):
            if state.get(target) == 1:
                return [*stack[stack.index(target) :], target]
            if target not in state and (found := visit(target)) is not None:
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)) is not None:
            return found
    return None


def _modules() -> dict[str, set[str]]:
    return {m: {t for t in ts if not t.startswith("+")} for m, ts in GRAPH.items()}


def _folder(module: str) -> str:
    return ".".join(module.split(".")[:2])


def test_the_graph_sees_the_package():
    assert "tinyrace.env" in GRAPH and "tinyrace.cars.dynamic" in GRAPH
    assert "tinyrace.cars.collision" in GRAPH["tinyrace.cars.dynamic"]
    assert "tinyrace.cars.state" in GRAPH["tinyrace.world.snapshot"]


def test_no_import_cycle_between_modules():
    assert _cycle(_modules()) is None


def test_no_import_cycle_between_folders():
    folders: dict[str, set[str]] = {}
    for module, targets in _modules().items():
        mine = _folder(module)
        folders.setdefault(mine, set()).update(_folder(t) for t in targets if _folder(t) != mine)
    assert _cycle(folders) is None


# The compiled twins: tinyrace.<layer>.kernels.<name>, beside their layer's plain twin.
COMPILER = "tinyrace.kernels.compiled"  # numba's compiler, in the bottom layer's kernels/


def _is_compiled_twin(module: str) -> bool:
    parts = module.split(".")
    return len(parts) == 4 and parts[2] == "kernels"


def test_the_compiled_twins_are_the_kernels_folders_of_the_layers():
    """A module compiles with numba exactly when it is in a layer's kernels/ folder."""
    twins = sorted(m for m in GRAPH if _is_compiled_twin(m))
    compiling = sorted(m for m, targets in GRAPH.items() if COMPILER in targets)
    assert twins and twins == compiling
    with_numba = sorted(m for m, targets in GRAPH.items() if "+numba" in targets)
    assert set(with_numba) <= {COMPILER, *twins}, "numba is imported only by compiled kernels"


def test_no_module_imports_both_pymunk_and_cv2():
    both = sorted(m for m, targets in GRAPH.items() if {"+pymunk", "+cv2"} <= targets)
    assert both == []


@pytest.mark.parametrize("module", sorted(GRAPH))
def test_imports_only_from_its_layer_or_below(module):
    upward = sorted(t for t in _modules()[module] if _layer(t) > _layer(module))
    assert upward == [], f"{module} (layer {_layer(module)}) imports from above: {upward}"


# Read-only layers see cars only as data: no physics engine, no live car classes.
PURE_CAR_DATA = ("tinyrace.cars.state", "tinyrace.cars.dynamic_shape")


@pytest.mark.parametrize(
    "module", sorted(m for m in GRAPH if m.split(".")[1:2] in (["render"], ["sensors"]))
)
def test_sensors_and_pictures_read_snapshots_not_the_physics(module):
    """render/ and sensors/ import no pymunk and no cars module but pure data."""
    targets = GRAPH[module]
    assert "+pymunk" not in targets
    cars = sorted(t for t in targets if t.startswith("tinyrace.cars") and t not in PURE_CAR_DATA)
    assert cars == [], f"{module} imports live car modules: {cars}"


def test_episodes_hold_rules_not_pictures():
    """episodes/ import no cv2 and nothing from render/."""
    for module in (m for m in GRAPH if m.startswith("tinyrace.episodes")):
        targets = GRAPH[module]
        assert "+cv2" not in targets, module
        assert not [t for t in targets if t.startswith("tinyrace.render")], module


def test_the_cycle_finder_finds_cycles():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


ARCHITECTURE = PACKAGE.parent / "docs" / "ARCHITECTURE.md"


def _drawn_layers() -> list[tuple[str, ...]]:
    """The layers of docs/ARCHITECTURE.md's first picture, bottom to top: each line that
    starts with module (``env.py``) or folder (``race/``) names is one layer."""
    text = ARCHITECTURE.read_text()
    picture = text.split("```", 2)[1]
    drawn = []
    for line in picture.splitlines():
        names = []
        for token in line.split():
            if not (token.endswith(".py") or token.endswith("/")):
                break
            names.append(token.removesuffix(".py").removesuffix("/"))
        if names:
            drawn.append(tuple(names))
    return drawn[::-1]


def test_the_layers_are_the_ones_the_architecture_page_draws():
    """The page's picture and LAYERS list the same layers in the same order."""
    assert [tuple(sorted(layer)) for layer in _drawn_layers()] == [
        tuple(sorted(layer)) for layer in LAYERS
    ]
