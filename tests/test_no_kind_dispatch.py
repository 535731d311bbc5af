"""Outside ``tinyrace/tracks/`` no code dispatches on a track's kind (issue 27, point 1).

Every module of the package outside ``tinyrace/tracks/`` is read with ``ast`` and these
are refused: a comparison with a track kind's name (``==``, ``!=``, ``in``, ``is``), a
table keyed by kind names (a dict with two kind keys or only kind keys, a set holding
one), any mention of ``METRIC_KINDS``, the ``kind`` of a track, config or source compared,
looked up in a table or used as a key, and ``isinstance``/``issubclass``/``case`` against
a class of the tracks or episodes layers or a ``*TrackConfig``. Cars, rules, sensors and
pictures ask what the track (or its config class) holds instead.

A kind's name may still appear as a label (messages, the results' ``track_kind``), as the
YAML ``type:`` discriminators of ``config/schema.py`` (``Literal["procedural"]`` and the
knob's default are neither a comparison nor a table, so they need no exception) and as
a homonym (the ``centerline`` driver, a results entry's ``image`` file).
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from tinyrace.config import EnvConfig
from tinyrace.ground.grounds import ImageGround, MetricGround, ProceduralGround, make_ground
from tinyrace.render.image_pictures import ImagePictures
from tinyrace.render.metric_pictures import MetricPictures
from tinyrace.render.procedural_pictures import ProceduralPictures
from tinyrace.render.setup import make_pictures
from tinyrace.tracks.base import PaintedGround, Track, TrackDraw
from tinyrace.tracks.registry import TRACK_SOURCES

ROOT = Path(__file__).resolve().parents[1] / "tinyrace"
KINDS = frozenset(TRACK_SOURCES)  # procedural, image, centerline, cone_map, ros_map
KIND_TABLE_NAMES = {"METRIC_KINDS", "METRIC_CONFIGS"}
# the base of a ``.kind`` that is a track's: track, config, env, source, layout, draw, ...
TRACKISH = re.compile(r"(track|config|env|source|layout|draw|loaded|parts|episode)", re.I)

# (file, kind name) -> why that comparison is not dispatch on a track kind
ALLOWED = {
    ("cli.py", "procedural"): "tinyrace show's argument 'procedural' names CarRacing's "
    "track when there is no file to read",
    ("validate.py", "procedural"): "the same CLI argument, passed on to picture()",
}

EXPECTED_KINDS = {"procedural", "image", "centerline", "cone_map", "ros_map"}


def _class_names() -> frozenset[str]:
    """Every class defined in the tracks and episodes layers."""
    names = set()
    for folder in ("tracks", "episodes"):
        for path in (ROOT / folder).rglob("*.py"):
            tree = ast.parse(path.read_text("utf-8"))
            names |= {n.name for n in ast.walk(tree) if isinstance(n, ast.ClassDef)}
    return frozenset(names)


CLASSES = _class_names()


def _is_kind(node: ast.AST) -> bool:
    return isinstance(node, ast.Constant) and node.value in KINDS


def _kind_in(node: ast.AST) -> str | None:
    """The kind name ``node`` is, or holds as a tuple, list or set element."""
    if _is_kind(node):
        return str(node.value)  # type: ignore[attr-defined]
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return next((str(e.value) for e in node.elts if _is_kind(e)), None)  # type: ignore[attr-defined]
    return None


def _dotted(node: ast.AST) -> str:
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return f"{_dotted(node.value)}.{node.attr}"
    if isinstance(node, ast.Subscript):
        return _dotted(node.value)
    if isinstance(node, ast.Call):
        return _dotted(node.func)
    return ""


def _track_kind(node: ast.AST) -> bool:
    """``<track|config|source|...>.kind`` (or ``.type``): the kind of a track or its config."""
    if not isinstance(node, ast.Attribute) or node.attr not in ("kind", "type"):
        return False
    base = _dotted(node.value).split(".")[-1]
    return bool(TRACKISH.search(base))


def _class_name(node: ast.AST) -> str | None:
    name = node.id if isinstance(node, ast.Name) else getattr(node, "attr", None)
    if name is None:
        return None
    if name in CLASSES or name.endswith("TrackConfig") or name in KIND_TABLE_NAMES:
        return name
    return None


def findings(source: str) -> Iterator[tuple[int, str, str | None]]:
    """(line, what, kind name or None) of every kind dispatch in ``source``."""
    for node in ast.walk(ast.parse(source)):
        line = getattr(node, "lineno", 0)
        if isinstance(node, ast.Compare):
            for operand in (node.left, *node.comparators):
                kind = _kind_in(operand)
                if kind is not None:
                    yield line, f"compares with the track kind {kind!r}", kind
                if _track_kind(operand):
                    yield line, f"compares {_dotted(operand)}", None
        elif isinstance(node, ast.Dict):
            keys = [k for k in node.keys if k is not None]
            kinds = {k.value for k in keys if _is_kind(k)}  # type: ignore[attr-defined]
            if len(kinds) >= 2 or (kinds and len(kinds) == len(node.keys)):  # no ** spread
                yield line, f"a table keyed by track kinds {sorted(kinds)}", None
            for key in keys:
                if _track_kind(key):
                    yield line, f"a table keyed by {_dotted(key)}", None
        elif isinstance(node, ast.Set):
            kind = _kind_in(node)
            if kind is not None:
                yield line, f"a set of track kinds holding {kind!r}", None
        elif isinstance(node, ast.Subscript) and _track_kind(node.slice):
            yield line, f"looks up {_dotted(node.slice)} in a table", None
        elif isinstance(node, ast.Call):
            yield from _call_findings(node, line)
        elif isinstance(node, ast.MatchClass) and _class_name(node.cls):
            yield line, f"matches the class {_class_name(node.cls)}", None
        elif isinstance(node, ast.Name) and node.id in KIND_TABLE_NAMES:
            yield line, f"reads {node.id}", None
        elif isinstance(node, ast.Attribute) and node.attr in KIND_TABLE_NAMES:
            yield line, f"reads {node.attr}", None
        elif isinstance(node, ast.alias) and node.name in KIND_TABLE_NAMES:
            yield line, f"imports {node.name}", None


def _call_findings(node: ast.Call, line: int) -> Iterator[tuple[int, str, str | None]]:
    func = _dotted(node.func)
    if func in ("isinstance", "issubclass") and len(node.args) == 2:
        classes = node.args[1]
        for cls in classes.elts if isinstance(classes, ast.Tuple) else [classes]:
            name = _class_name(cls)
            if name is not None:
                yield line, f"{func}(..., {name})", None
    if func.endswith(".get") and node.args and _track_kind(node.args[0]):
        yield line, f"looks up {_dotted(node.args[0])} in a table", None
    if func.endswith("fromkeys") and node.args and _kind_in(node.args[0]):
        yield line, "a table keyed by track kinds (fromkeys)", None


def _sources() -> list[Path]:
    return sorted(p for p in ROOT.rglob("*.py") if "tracks" not in p.relative_to(ROOT).parts[:1])


def test_the_kinds_are_the_registered_track_sources():
    assert KINDS == EXPECTED_KINDS  # a new kind: add it here, the test then guards it too


def test_the_sources_cover_the_layers_above_tracks():
    folders = {
        p.relative_to(ROOT).parts[0] for p in _sources() if len(p.relative_to(ROOT).parts) > 1
    }
    assert {"config", "cars", "world", "sensors", "render", "episodes", "experiment"} <= folders
    assert "tracks" not in folders
    assert {"ProceduralTrack", "ImageTrack", "MetricTrack", "Track", "Episode"} <= CLASSES


@pytest.mark.parametrize("path", _sources(), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_code_outside_tracks_dispatches_on_a_track_kind(path: Path):
    relative = str(path.relative_to(ROOT))
    found = [
        f"{relative}:{line}: {what}"
        for line, what, kind in findings(path.read_text("utf-8"))
        if (relative, kind) not in ALLOWED
    ]
    assert not found, "dispatch on a track kind (ask what the track holds):\n" + "\n".join(found)


def test_every_allowed_comparison_is_still_there():
    """An exception that no longer matches anything is dropped from ALLOWED."""
    for relative, kind in ALLOWED:
        kinds = {k for _, _, k in findings((ROOT / relative).read_text("utf-8"))}
        assert kind in kinds, relative


FORBIDDEN = {
    'if config.kind == "procedural": pass': "compares",
    'x = track.type in ("centerline", "cone_map")': "compares with the track kind",
    'if "image" in kinds: pass': "compares with the track kind 'image'",
    "PICTURES = {'procedural': A, 'image': B}": "a table keyed by track kinds",
    "PICTURES = {'ros_map': A}": "a table keyed by track kinds",
    "units = frozenset({'image'})": "a set of track kinds",
    "build = PICTURES.get(source.kind)": "looks up source.kind",
    "build = PICTURES[self.config.kind]": "looks up self.config.kind",
    "table = dict.fromkeys(('centerline', 'ros_map'), M)": "fromkeys",
    "from tinyrace.config import METRIC_KINDS": "imports METRIC_KINDS",
    "metric = kind in schema.METRIC_KINDS": "reads METRIC_KINDS",
    "if isinstance(track.detail, MetricTrack): pass": "isinstance(..., MetricTrack)",
    "ok = isinstance(t, (int, RosMapTrackConfig))": "isinstance(..., RosMapTrackConfig)",
    "if isinstance(e, episodes.Episode): pass": "isinstance(..., Episode)",
    "match track:\n    case ProceduralTrack(): pass": "matches the class ProceduralTrack",
}


@pytest.mark.parametrize("snippet", FORBIDDEN)
def test_the_check_flags_each_forbidden_dispatch(snippet: str):
    whats = [what for _, what, _ in findings(snippet)]
    assert any(FORBIDDEN[snippet] in what for what in whats), whats


def test_the_check_leaves_labels_homonyms_and_other_kinds_alone():
    clean = "\n".join(
        [
            'print(f"{config.kind} track")',  # a label in a message
            'header = {"track_kind": env.config.kind, "image": name, "frame": frame}',
            'entry = {**entry, "image": str(image)}',  # a results entry's picture file
            'DRIVERS = {"random": R, "constant": C, "centerline": D}',  # the driver's name
            'if spec.kind == "discrete": pass',  # an action space's kind
            'if example.kind == "track": pass',  # an example's kind
            'type: Literal["procedural"] = knob("procedural", "track kind")',
            "ok = isinstance(value, (bool, np.bool_))",
            "if track.unit == CARRACING_UNIT: pass",
        ]
    )
    assert list(findings(clean)) == []


class _ToySource:
    """A track source of a kind nothing knows: its pictures follow what its tracks hold."""

    kind = "toy"

    def __init__(self, painted: PaintedGround | None = None, **holds: object):
        self.painted = painted
        track = Track("toy", "px", None, True, (0.0, 0.0, 8.0, 8.0), ((4.0, 4.0, 0.0),), **holds)
        self.tracks = () if painted is not None else (track,)

    def draw(self, rng: object, options: object) -> TrackDraw:
        raise NotImplementedError


@pytest.mark.parametrize(
    ("source", "ground", "pictures"),
    [
        (_ToySource(PaintedGround(50.0, 1.0)), ProceduralGround, ProceduralPictures),
        (_ToySource(picture=np.zeros((8, 8, 4), np.uint8)), ImageGround, ImagePictures),
        (_ToySource(walls=np.array([[0.0, 0.0, 1.0, 1.0]])), MetricGround, MetricPictures),
    ],
    ids=["painted ground", "picture", "drawn ground"],
)
def test_ground_and_pictures_follow_what_the_tracks_hold_not_their_kind(source, ground, pictures):
    made = make_ground(EnvConfig(), source)  # the one ground of the sensors and the pictures
    assert type(made) is ground
    assert type(make_pictures(EnvConfig(), made)) is pictures
