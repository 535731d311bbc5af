"""Hostile track.yaml and experiment files: a working env, or a ConfigError naming the key path.

Hypothesis starts from the shipped example tracks (shrunk eightfold, so that an
example builds in milliseconds) and the shipped experiment files, then mutates
them: junk values of every type, odd numbers (0, negative, huge, NaN, inf, floats
for ints, strings for numbers), the schema's own bounds and one step past them,
missing and unknown keys, unknown track types, broken images (garbage bytes, an
empty file, a truncated PNG, a directory) and broken YAML text. Each case must
end in an env that resets and steps, or in ``tinyrace.errors.ConfigError``;
no other exception may escape.
"""

from __future__ import annotations

import copy
import dataclasses
import itertools
import math
import os
import re
import typing
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from hypothesis.control import currently_in_test_context
from hypothesis_budget import examples

from tinyrace.config import load_env_config
from tinyrace.config.experiment import ExperimentConfig
from tinyrace.config.schema import EnvConfig
from tinyrace.env import TinyRaceEnv
from tinyrace.errors import ConfigError, Problem
from tinyrace.examples import CONFIGS_DIR, TRACKS_DIR
from tinyrace.experiment import experiment_from_dict, load_experiment

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE_NAMES = ("segmented", "formula_student", "carolo_cup")
SHRINK = 8  # example images, spawns and car sizes are divided by this

# Hypothesis settings shared by the fuzzing tests: no per-example deadline (a few
# procedural examples generate a track: ~30 ms), fixed examples on CI.
FUZZ = {
    "deadline": None,
    "derandomize": bool(os.environ.get("CI")),
    "suppress_health_check": [HealthCheck.too_slow, HealthCheck.data_too_large],
}
TRACK_EXAMPLES = examples(600)  # a quarter of these in the README's quick run
EXPERIMENT_EXAMPLES = examples(300)
YAML_TEXT_EXAMPLES = examples(120)  # 1020 in total on CI, ~10 s


# -- the workspace: shrunk example tracks, broken images, experiment files -------------------
@dataclasses.dataclass(frozen=True)
class Workspace:
    root: Path
    tracks: dict[str, Path]  # name -> folder of a shrunk example track
    bases: dict[str, dict]  # name -> raw track.yaml mapping (images relative to its folder)
    experiments: dict[str, dict]  # configs/*.yaml stem -> raw mapping (relative to root/configs)
    broken: dict[str, str]  # kind -> file name (in root/images) of a broken or odd image


def _shrink_track(name: str, target: Path) -> dict:
    """An example track folder at 1/SHRINK scale: same keys, same colours, small image."""
    source = TRACKS_DIR / name
    raw = yaml.safe_load((source / "track.yaml").read_text())
    image = cv2.imread(str(source / raw["tracks"][0]["image"]), cv2.IMREAD_COLOR)
    small = cv2.resize(
        image,
        (image.shape[1] // SHRINK, image.shape[0] // SHRINK),
        interpolation=cv2.INTER_NEAREST,  # keeps the pure colours
    )
    target.mkdir(parents=True)
    assert cv2.imwrite(str(target / raw["tracks"][0]["image"]), small)
    for track in raw["tracks"]:
        track["spawns"] = [[x / SHRINK, y / SHRINK, a] for x, y, a in track["spawns"]]
    for key in ("wheelbase", "track_width", "velocity"):
        raw["car"][key] = raw["car"][key] / SHRINK
    _shrink_cameras(raw["cameras"])
    (target / "track.yaml").write_text(yaml.safe_dump(raw, sort_keys=False))
    return raw


def _shrink_cameras(cameras: list[dict]) -> None:
    for camera in cameras:
        camera["roi"] = [v / SHRINK for v in camera["roi"]]
        camera["position"] = [v / SHRINK for v in camera.get("position", [0, 0])]
        camera["resolution"] = [v // 4 for v in camera["resolution"]]


def _shrunk_experiment(path: Path) -> dict:
    """An experiment file whose inline cameras fit the shrunk example tracks."""
    raw = yaml.safe_load(path.read_text())
    _shrink_cameras(raw["env"].get("cameras", []))
    return raw


def _broken_images(folder: Path) -> dict[str, str]:
    folder.mkdir(parents=True)
    good = np.zeros((48, 64, 3), np.uint8)
    good[10:20, 10:20] = (255, 0, 0)
    assert cv2.imwrite(str(folder / "good.png"), good)
    png = (folder / "good.png").read_bytes()
    rng = np.random.default_rng(0)
    files = {
        "garbage": ("garbage.png", rng.integers(0, 256, 600, np.uint8).tobytes()),
        "empty": ("empty.png", b""),
        "truncated": ("truncated.png", png[: len(png) // 2]),
        "header_only": ("header.png", png[:33]),
        "text": ("text.png", b"not an image\n"),
        "png_named_jpg": ("really_png.jpg", png),
    }
    for name, data in files.values():
        (folder / name).write_bytes(data)
    (folder / "directory.png").mkdir()
    assert cv2.imwrite(str(folder / "one_pixel.png"), np.zeros((1, 1, 3), np.uint8))
    assert cv2.imwrite(str(folder / "grey16.png"), np.full((40, 50), 60000, np.uint16))
    assert cv2.imwrite(str(folder / "rgba.png"), np.full((40, 50, 4), 255, np.uint8))
    names = {kind: name for kind, (name, _) in files.items()}
    return {
        **names,
        "directory": "directory.png",
        "missing": "missing.png",
        "one_pixel": "one_pixel.png",
        "grey16": "grey16.png",
        "rgba": "rgba.png",
        "good": "good.png",
    }


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Workspace:
    root = tmp_path_factory.mktemp("hardening")
    tracks = {name: root / "tracks" / name for name in EXAMPLE_NAMES}
    bases: dict[str, dict] = {name: _shrink_track(name, tracks[name]) for name in EXAMPLE_NAMES}
    bases["procedural"] = {}
    bases["procedural_cameras"] = {
        "track": {"type": "procedural", "domain_randomize": True},
        "cameras": [{"id": "ahead", "resolution": [24, 32], "roi": [40, 50], "yaw": 10}],
        "reward_design": {"off_road_penalty": 0.5},
    }
    # CarRacing's car keeps its size on the shrunk picture, where it would start on cones:
    # the same track without them
    bases["dynamic_on_image"] = {
        **copy.deepcopy(bases["formula_student"]),
        "car": {"model": "dynamic"},
    }
    bases["dynamic_on_image"]["reward_design"].pop("color_obstacles")
    # experiments keep their relative track folders: ../tracks/<name> from configs/
    (root / "configs").mkdir()
    experiments = {
        path.stem: _shrunk_experiment(path) for path in sorted((CONFIGS_DIR).glob("*.yaml"))
    }
    return Workspace(root, tracks, bases, experiments, _broken_images(root / "images"))


# -- mutations -----------------------------------------------------------------------------
# YAML 1.1 reads NEL, LS and PS as line breaks even inside a written key, and PyYAML writes
# but cannot read back a lone surrogate, so such a key is not the key the file holds; new
# keys are drawn without them.
_YAML_BREAKS = "\x85\u2028\u2029"


def key_text(**sizes: int) -> st.SearchStrategy[str]:
    return st.text(
        st.characters(exclude_characters=_YAML_BREAKS, exclude_categories=("Cs",)), **sizes
    )


Path_ = tuple  # a key path into a raw mapping: keys and list indices


def _nodes(tree: Any, prefix: Path_ = ()) -> list[tuple[Path_, Any]]:
    """Every (path, value) of a raw YAML tree, the root first."""
    found = [(prefix, tree)]
    if isinstance(tree, Mapping):
        for key, value in tree.items():
            found += _nodes(value, (*prefix, key))
    elif isinstance(tree, list):
        for index, value in enumerate(tree):
            found += _nodes(value, (*prefix, index))
    return found


def _set(tree: Any, path: Path_, value: Any) -> Any:
    if not path:
        return value
    _get(tree, path[:-1])[path[-1]] = value
    return tree


def _get(tree: Any, path: Path_) -> Any:
    for key in path:
        tree = tree[key]
    return tree


def _dotted(path: Path_) -> str:
    text = ""
    for key in path:
        text += f"[{key}]" if isinstance(key, int) else (f".{key}" if text else str(key))
    return text


JUNK_SCALARS = [
    None, True, False, 0, -1, 1, 0.5, -0.5, 1.5, 2**31, 10**12, 10**400, 1e308, -1e308,
    math.nan, math.inf, -math.inf, "", " ", "abc", "12", "1e3", "nan", "#ff00zz", "#00ff00",
    "x" * 300, "done", "procedural", "image",
]  # fmt: skip
JUNK_CONTAINERS = [
    [], [1], [1, 2], [1, 2, 3, 4], [[1, 2, 3]], ["a", "b"], [None], [math.nan, 1.0],
    {}, {"x": 1}, {"type": "procedural"}, {"type": "lines"}, {"junk": [1, {"deep": None}]},
]  # fmt: skip
# Values no YAML file holds but a dict or gym.make kwargs can.
PYTHON_ONLY = [
    np.array([1, 2]), np.float64("nan"), np.int64(5), np.float32(2.5), (1, 2), b"\xff", {1, 2},
    object(), 1 + 2j,
]  # fmt: skip
NESTED_JUNK = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=6),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(key_text(max_size=6), inner, max_size=3)
    ),
    max_leaves=8,
)
YAML_JUNK = st.sampled_from(JUNK_SCALARS + JUNK_CONTAINERS) | NESTED_JUNK
ANY_JUNK = YAML_JUNK | st.sampled_from(PYTHON_ONLY)
TRACK_TYPES = ["image", "procedural", "lines", "Procedural", "", 3, None, ["procedural"], {}]
NUMBER_TWEAKS = ["negate", "zero", "half", "float", "string", "times_1e6", "plus_half"]
BOUNDS = ["low", "high", "below", "above"]


def mutation(junk: st.SearchStrategy, images: bool) -> st.SearchStrategy:
    """One mutation: what to do and a selector that picks where (modulo the candidates)."""
    where = st.integers(0, 10**6)
    options = [
        st.tuples(st.just("set"), where, junk),
        st.tuples(st.just("delete"), where),
        st.tuples(st.just("add"), where, key_text(min_size=1, max_size=8), junk),
        st.tuples(st.just("number"), where, st.sampled_from(NUMBER_TWEAKS)),
        st.tuples(st.just("bound"), where, st.sampled_from(BOUNDS)),
        st.tuples(st.just("type"), where, st.sampled_from(TRACK_TYPES)),
    ]
    if images:
        options.append(st.tuples(st.just("image"), where, st.sampled_from(BROKEN_KINDS)))
    return st.one_of(options)


BROKEN_KINDS = [
    "garbage", "empty", "truncated", "header_only", "text", "png_named_jpg", "directory",
    "missing", "one_pixel", "grey16", "rgba", "good",
]  # fmt: skip


def _schema_meta(schema: type, path: Path_) -> Mapping[str, Any] | None:
    """The field metadata (low, high, ...) of the number at ``path``, if the schema has it."""
    hint: Any = schema
    meta: Mapping[str, Any] | None = None
    for key in path:
        hint = _unwrap(hint)
        if isinstance(key, str) and typing.get_origin(hint) is tuple:
            hint = _unwrap(typing.get_args(hint)[0])  # a mapping stands for a list of one
        if isinstance(key, int):
            args = typing.get_args(hint)
            if typing.get_origin(hint) is not tuple or not args:
                return None
            hint = args[0] if args[-1] is Ellipsis or len(args) <= key else args[key]
            continue
        members = [m for m in _members(hint) if dataclasses.is_dataclass(m)]
        fields = {
            name: f
            for m in members
            for f in dataclasses.fields(m)
            for name in (f.name, *f.metadata.get("aliases", ()))
        }
        if key not in fields:
            return None
        meta = fields[key].metadata
        hint = typing.get_type_hints(
            next(m for m in members if fields[key] in dataclasses.fields(m))
        )[fields[key].name]
        if key == "env" and typing.get_origin(hint) is dict:  # an experiment's env sections
            hint = EnvConfig
    return meta


def _members(hint: Any) -> tuple:
    return (
        typing.get_args(hint)
        if typing.get_origin(hint) in (typing.Union, type(int | None))
        else (hint,)
    )


def _unwrap(hint: Any) -> Any:
    """Optional[X] -> X; a tuple of one dataclass kind stays a tuple."""
    members = [m for m in _members(hint) if m is not type(None)]
    return members[0] if len(members) == 1 else hint


def _bound(meta: Mapping[str, Any] | None, which: str, current: Any) -> Any:
    low, high = (meta or {}).get("low"), (meta or {}).get("high")
    if which in ("low", "below") and low is not None:
        return low if which == "low" else low - 1
    if which in ("high", "above") and high is not None:
        return high if which == "high" else high + 1
    return current


def _tweak(value: Any, how: str) -> Any:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return value
    tweaks: dict[str, Callable[[Any], Any]] = {  # lazy: a huge int overflows float()
        "negate": lambda v: -v,
        "zero": lambda v: 0,
        "half": lambda v: v / 2,
        "float": float,
        "string": str,
        "times_1e6": lambda v: v * 1_000_000,
        "plus_half": lambda v: v + 0.5,
    }
    try:
        return tweaks[how](value)
    except OverflowError:
        return str(value)  # still a hostile value: a number written as text


# A bound that is valid but only costs memory: a 20000 x 20000 black plane is 1.6 GB.
HEAVY_BOUNDS = {("plane_size", "high")}


def apply(
    raw: Any, mutations: list[tuple], schema: type, images: dict[str, str] | None
) -> tuple[Any, list[str]]:
    """Apply each mutation to a deep copy of ``raw``; return it and the mutated key paths."""
    tree, touched = copy.deepcopy(raw), []
    for op, selector, *args in mutations:
        nodes = _nodes(tree)
        if op == "set":
            path = nodes[selector % len(nodes)][0]
            tree = _set(tree, path, copy.deepcopy(args[0]))
        elif op == "delete":
            inner = [p for p, _ in nodes if p]
            if not inner:
                continue
            path = inner[selector % len(inner)]
            del _get(tree, path[:-1])[path[-1]]
            if isinstance(path[-1], int):  # the later entries move up: the list is touched
                path = path[:-1]
        elif op == "add":
            maps = [p for p, v in nodes if isinstance(v, dict)]
            if not maps:
                continue
            path = (*maps[selector % len(maps)], args[0])
            _get(tree, path[:-1])[args[0]] = copy.deepcopy(args[1])
        elif op in ("number", "bound"):
            numbers = [
                (p, v)
                for p, v in nodes
                if isinstance(v, (int, float)) and not isinstance(v, bool) and p
            ]
            if not numbers:
                continue
            path, value = numbers[selector % len(numbers)]
            if op == "number":
                new = _tweak(value, args[0])
            else:
                key = next((k for k in reversed(path) if isinstance(k, str)), "")
                if (key, args[0]) in HEAVY_BOUNDS:
                    continue
                new = _bound(_schema_meta(schema, path), args[0], value)
            tree = _set(tree, path, new)
        else:  # "type" or "image": a key of one track entry
            path, entry = _track_entry(tree, selector)
            if entry is None:
                continue
            key = "type" if op == "type" else "image"
            if op == "image":
                if images is None:
                    continue
                entry[key] = images[args[0]]
            else:
                entry[key] = copy.deepcopy(args[0])
            path = (*path, key)
        touched.append(_dotted(path))
    return tree, touched


def _track_entry(tree: Any, selector: int) -> tuple[Path_, dict | None]:
    """A track mapping of the tree (under tracks/track, or env.tracks/env.track)."""
    entries = [
        (p, v)
        for p, v in _nodes(tree)
        if isinstance(v, dict) and any(k in ("track", "tracks") for k in p if isinstance(k, str))
        and (p[-1] in ("track",) or isinstance(p[-1], int))
    ]  # fmt: skip
    if not entries:
        return (), None
    return entries[selector % len(entries)]


# -- the oracle ------------------------------------------------------------------------------
# Problems that may legitimately surface away from the key that was mutated.
CROSS_RULES = [
    r"tracks(\[\d+\])?",  # no track, mixed kinds, or no closed procedural lap
    r"cameras",  # an image track needs a camera
    r"cameras\[\d+\]\.(roi|id)",  # roi larger than the image; duplicate ids
    r"tracks\[\d+\]\.spawns\[\d+\]",  # a spawn outside a changed image
    r"tracks\[\d+\]\.pixels_per_unit",  # the ground texture's side (playfield * ppu)
    r"car\.actions",  # discrete actions need the dynamic car
    r"reward_design\.color_obstacles",  # colour obstacles need an image track
    r"reward_design\.color_obstacles\[\d+\]\.color",  # the trajectory's colour: never hit
    r"reward_design\.cross_track_error\.trajectory_color",  # colour absent from the image
    r"environment",  # the track folder of an experiment
]


def _plain(path: str) -> str:
    """A key path without the experiment's env. prefix and with plural section names."""
    path = re.sub(r"^env\.?", "", path)
    return re.sub(r"^(track|camera)(?=[.\[]|$)", r"\1s", path)


def _normal(path: str) -> str:
    """Compare key paths modulo spelling: a mapping also stands for a list of one."""
    return re.sub(r"^(tracks|cameras)\[0\]", r"\1", _plain(path))


def _related(problem: str, mutated: str) -> bool:
    """Same key, one inside the other, or a sibling of a changed ``type`` (it reinterprets them)."""
    a, b = _normal(problem), _normal(mutated)
    if b.endswith(".type") or b == "type":
        b = b[: -len("type")].rstrip(".")
    if a == b or not a or not b:
        return a == b or not b
    return any(x.startswith(y) and x[len(y)] in ".[" for x, y in ((a, b), (b, a)))


def check_config_error(err: ConfigError, touched: list[str], free_paths: bool = False) -> None:
    """The error lists problems; each names its source and key path, one the mutated key."""
    text = str(err)
    assert err.problems, text
    for problem in err.problems:
        assert problem.source and problem.source in text, text
        assert problem.allowed.strip(), text
        if free_paths:  # a broken YAML file or a root that is not a mapping
            continue
        # a key path; empty only for a key that is itself the empty string
        assert problem.path or problem.allowed.startswith("unknown key"), text
        assert problem.path in text, text
    if free_paths:
        return
    paths = [p.path for p in err.problems]
    relevant = any(_related(p, m) for p in paths for m in touched) or any(
        re.fullmatch(rule, _plain(p)) for p in paths for rule in CROSS_RULES
    )
    assert relevant, f"no problem names a mutated key {touched}: {text}"


def drive(env: TinyRaceEnv, steps: int = 3) -> None:
    """reset + a few steps: observations in the space, finite rewards and poses."""
    try:
        observation, info = env.reset(seed=0)
        assert env.observation_space.contains(observation)
        env.action_space.seed(0)
        for _ in range(steps):
            observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
            assert env.observation_space.contains(observation)
            assert isinstance(reward, float) and math.isfinite(reward), reward
            assert all(math.isfinite(v) for v in info["pose"]), info["pose"]
            assert isinstance(terminated, bool) and isinstance(truncated, bool)
            if terminated or truncated:
                env.reset()
    finally:
        env.close()


def build_and_drive(make) -> ConfigError | None:
    """None when the env works; the ConfigError when it is refused. Anything else escapes."""
    try:
        env = make()
        drive(env)
    except ConfigError as err:
        _event("ConfigError")
        return err
    _event("a working env")
    return None


def _event(outcome: str) -> None:
    """Count outcomes in hypothesis' statistics (--hypothesis-show-statistics)."""
    if currently_in_test_context():
        event(outcome)


def _absolute_images(tree: Any, folder: Path) -> Any:
    """A dict config has no folder: point its image names at files in ``folder``."""
    for path, value in _nodes(tree):
        if path and path[-1] == "image" and isinstance(value, str):
            _set(tree, path, str(folder / value))
    return tree


def _yaml_text(tree: Any) -> str | None:
    try:
        return yaml.safe_dump(tree, sort_keys=False, allow_unicode=True)
    except yaml.YAMLError:
        return None


_counter = itertools.count()

# -- track.yaml fuzzing ------------------------------------------------------------------


@settings(max_examples=TRACK_EXAMPLES, **FUZZ)
@given(
    base=st.sampled_from(
        [
            "segmented",
            "formula_student",
            "carolo_cup",
            "procedural",
            "procedural_cameras",
            "dynamic_on_image",
        ]
    ),
    as_file=st.booleans(),
    mutations=st.data(),
)
def test_mutated_track_yaml_works_or_names_the_key(workspace, base, as_file, mutations):
    junk = YAML_JUNK if as_file else ANY_JUNK
    ops = mutations.draw(st.lists(mutation(junk, images=True), min_size=1, max_size=3))
    raw = workspace.bases[base]
    folder = workspace.tracks.get(base.replace("dynamic_on_image", "formula_student"))
    tree, touched = apply(raw, ops, EnvConfig, _image_names(workspace, folder))
    text = _yaml_text(tree) if as_file else None
    if text is not None:
        # next to the base's own image, so that relative names resolve as in a track folder
        path = (folder or workspace.root) / f"case_{next(_counter)}.yaml"
        path.write_text(text)
        err = build_and_drive(lambda: TinyRaceEnv(config=path))
        source = str(path)
    else:
        tree = _absolute_images(tree, folder or workspace.root) if folder else tree
        err = build_and_drive(lambda: TinyRaceEnv(config=tree))
        # a root that is not a mapping is taken for a path (a string) or refused as a kwarg
        source = "<dict>" if isinstance(tree, Mapping) else None
    if err is not None:
        assert source is None or all(p.source == source for p in err.problems), str(err)
        check_config_error(err, touched, free_paths=not isinstance(tree, Mapping))


def _image_names(workspace: Workspace, folder: Path | None) -> dict[str, str]:
    """Broken image names as seen from ``folder`` (relative, as track.yaml writes them)."""
    here = folder or workspace.root
    return {
        kind: os.path.relpath(workspace.root / "images" / name, here)
        for kind, name in workspace.broken.items()
    }


YAML_DAMAGE = [
    "\t", ": :", "{", "]", "- - -", "&a *b", "key: [1, 2", "!!python/object:os.system x",
    "\x00", "'", '"', "? ", "%YAML 9.9\n", "--- !!binary AAAA", "\n  bad indent: 1\n",
]  # fmt: skip


@settings(max_examples=YAML_TEXT_EXAMPLES, **FUZZ)
@given(
    base=st.sampled_from(["segmented", "formula_student", "carolo_cup", "procedural_cameras"]),
    cut=st.floats(0, 1),
    damage=st.sampled_from(YAML_DAMAGE),
    binary=st.binary(max_size=12),
    how=st.sampled_from(["insert", "truncate", "bytes"]),
)
def test_damaged_yaml_text_works_or_is_a_config_error(workspace, base, cut, damage, binary, how):
    folder = workspace.tracks.get(base, workspace.root / "tracks" / "formula_student")
    text = yaml.safe_dump(workspace.bases[base], sort_keys=False).encode()
    at = int(cut * len(text))
    if how == "insert":
        data = text[:at] + damage.encode() + text[at:]
    elif how == "truncate":
        data = text[:at]
    else:
        data = text[:at] + binary + text[at:]
    path = folder / f"damaged_{next(_counter)}.yaml"
    path.write_bytes(data)
    err = build_and_drive(lambda: TinyRaceEnv(config=path))
    if err is not None:
        check_config_error(err, [], free_paths=True)
        assert str(path) in str(err)


# -- experiment fuzzing ----------------------------------------------------------------------
# Names longer than the OS allows and names with a NUL byte are pinned by the two tests
# below (they used to escape experiment/load.py as OSError / ValueError).
EXPERIMENT_JUNK = YAML_JUNK  # odd names included: too long, NUL bytes


@settings(max_examples=EXPERIMENT_EXAMPLES, **FUZZ)
@given(
    name=st.sampled_from(
        ["carracing", "carracing_discrete", "formula_student", "multi_camera", "carolo_cup"]
    ),
    as_file=st.booleans(),
    mutations=st.lists(mutation(EXPERIMENT_JUNK, images=False), min_size=1, max_size=3),
)
def test_mutated_experiment_works_or_names_the_key(workspace, name, as_file, mutations):
    base_dir = workspace.root / "configs"
    tree, touched = apply(workspace.experiments[name], mutations, ExperimentConfig, None)
    try:
        if as_file:
            path = base_dir / f"experiment_{next(_counter)}.yaml"
            path.write_text(yaml.safe_dump(tree, sort_keys=False))
            experiment = load_experiment(path)
        else:
            experiment = experiment_from_dict(tree, "<experiment>", base_dir)
    except ConfigError as err:
        check_config_error(err, touched, free_paths=not isinstance(tree, Mapping))
        return
    err = build_and_drive(lambda: TinyRaceEnv(**experiment.env_kwargs))
    if err is not None:
        check_config_error(err, touched)


# -- the bugs the fuzzing found, pinned as plain examples --------------------------------------
PLANE = {"tracks": [{"image": None, "plane_size": [64, 64], "spawns": [[10, 32, 0]]}]}
SMALL_CAMERA = {"cameras": [{"id": "a", "resolution": [8, 8], "roi": [16, 16]}]}


@pytest.mark.parametrize(
    ("config", "path"),
    [
        ({"sim": {"fps": 10**400}}, "sim.fps"),  # was OverflowError
        ({"reward_design": {"cross_track_error": {"weight": 10**400}}}, "weight"),
        ({"reward_design": {"time_penalty": 1e300}}, "reward_design.time_penalty"),  # inf score
        ({"car": {"model": np.array([1, 2])}}, "car.model"),  # was ValueError (ambiguous truth)
        ({"track": {"type": ["procedural"]}}, "track.type"),  # was TypeError (unhashable)
        ({"track": {"type": {"a": 1}}}, "track.type"),
        ({**SMALL_CAMERA, "tracks": [{"image": "x" * 300}]}, "tracks[0].image"),  # was OSError
        ({"track": {"type": "procedural", "playfield": 10000}}, "track.pixels_per_unit"),
        ({"track": {"type": "procedural", "pixels_per_unit": 16}}, "track.pixels_per_unit"),
        ({**PLANE, **SMALL_CAMERA, "cameras": [{"id": "a", "position": [1e300, 0]}]}, "position"),
    ],
)
def test_found_bugs_are_config_errors(config, path):
    """Each once escaped as another exception (or a MemoryError, or an inf reward)."""
    with pytest.raises(ConfigError) as caught:
        drive(TinyRaceEnv(config=config))
    assert any(path in p.path for p in caught.value.problems), str(caught.value)


@pytest.mark.parametrize("track", [{"radius": 2000}, {"detail_step": 0.5}])
def test_a_procedural_track_that_never_closes_is_a_config_error_at_reset(track):
    env = TinyRaceEnv(config={"track": {"type": "procedural", **track}})
    with pytest.raises(ConfigError, match=r"tracks\[0\].*radius"):
        env.reset(seed=0)


def test_every_base_works_unmutated(workspace):
    """The fuzzing starts from working configs: otherwise every case would be an error."""
    for name, raw in workspace.bases.items():
        folder = workspace.tracks.get(name.replace("dynamic_on_image", "formula_student"))
        tree = _absolute_images(copy.deepcopy(raw), folder) if folder else raw
        assert build_and_drive(lambda tree=tree: TinyRaceEnv(config=tree)) is None, name
    for name, raw in workspace.experiments.items():
        experiment = experiment_from_dict(raw, name, workspace.root / "configs")
        assert build_and_drive(lambda e=experiment: TinyRaceEnv(**e.env_kwargs)) is None, name


def test_broken_images_are_config_errors_naming_the_image_key(workspace):
    folder = workspace.tracks["formula_student"]
    names = _image_names(workspace, folder)
    for kind in ("garbage", "empty", "truncated", "header_only", "text", "directory", "missing"):
        tree = copy.deepcopy(workspace.bases["formula_student"])
        tree["tracks"][0]["image"] = names[kind]
        path = folder / f"broken_{kind}.yaml"
        path.write_text(yaml.safe_dump(tree))
        err = build_and_drive(lambda path=path: TinyRaceEnv(config=path))
        assert err is not None, kind
        assert [p.path for p in err.problems] == ["tracks[0].image"], str(err)


def test_the_oracle_rejects_an_error_that_names_no_mutated_key():
    """check_config_error can fail: a problem about another key does not count."""
    err = ConfigError(Problem("<dict>", "sim.fps", 0, "expected more"))
    with pytest.raises(AssertionError):
        check_config_error(err, ["car.wheelbase"])
    check_config_error(err, ["sim"])


def test_experiment_with_an_overlong_environment_name_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError):
        experiment_from_dict({"env": {"environment": "x" * 300}}, "<e>", tmp_path)


def test_experiment_with_a_nul_in_an_image_name_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError):
        experiment_from_dict({"env": {"track": {"image": "a\x00b"}}}, "<e>", tmp_path)


@pytest.mark.parametrize("key", ["[", "]", ".", "[]."])
def test_a_key_of_brackets_alone_is_named_in_the_dict_that_holds_it(key):
    """Found by the mutation test above: a top-level key with no name in it was blamed on
    the keyword arguments, which gave none."""
    with pytest.raises(ConfigError) as caught:
        load_env_config({key: None})
    assert [(p.source, p.path) for p in caught.value.problems] == [("<dict>", key)]
    with pytest.raises(ConfigError) as caught:
        load_env_config(None, overrides={key: None})
    assert [(p.source, p.path) for p in caught.value.problems] == [("<kwargs>", key)]
