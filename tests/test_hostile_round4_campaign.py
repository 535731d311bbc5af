"""Issue 39.1: a seeded campaign over races, per-car actions (both PettingZoo forms), reset
options, opponents, camera_info files and the cache folder.

Every case runs in a worker process under an address-space limit and an alarm
(tests/hostile_worker.py, with the kinds of tests/hostile_race_cases.py) and must end in a
clear error (a ConfigError whose problems name the key, file or opponent and the value; an
InvalidAction naming the car) or a working env with finite observations inside each car's
space. Where the input's validity is known here (an action, a car id, an opponent's
controls), the outcome must match it: nothing invalid accepted, nothing valid refused. No
input file's bytes may change, the cache removes nothing it did not write, and no process
is left behind. The same cases run every time (``SEED``); ``HYPOTHESIS_PROFILE=ci`` runs
twice as many. The case count and the outcomes are printed.
"""

from __future__ import annotations

import collections
import math
import os
import random
import secrets
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from test_hostile_campaign import Campaign, digests, unchanged

from tinyrace import cache
from tinyrace.cache import disk
from tinyrace.config.bounds import MAX_CAMERA_PIXELS, PERSPECTIVE_PIXEL_WEIGHT, id_problem

SEED = 39
SECONDS = 20  # [s] per case (a race of 16 cars with cameras builds in a few seconds)
SCALE = 2 if os.environ.get("HYPOTHESIS_PROFILE") == "ci" else 1
CASES = {"race_config": 200, "action": 400, "reset": 130, "opponents": 120,
         "camera_info": 110, "cache": 110}  # fmt: skip
MIN_CASES = 1000
NAN, INF = float("nan"), float("inf")

# -- hostile values ------------------------------------------------------------------------------
IDS = ["écurie", "a,b", "x/y", "x?y", "car_0", "", " ", "a b", "tab\t", "nl\n", "a" * 64,
       "a" * 65, "日本", "..", ".", "nul\x00", "CON", "ß", "A", "a", "-rf", "$HOME", "%s",
       5, None, True, ["x"]]  # fmt: skip
NUMBERS = [0, -1, 0.5, 1.2, 2.5, 10, 1e3, 1e9, 1e308, NAN, INF, -INF, "2", None, True, [1]]
COUNTS = [1, 2, 3, 4, 16, 17, 0, -1, "2", 2.5, None, True]


def perspective(rng: random.Random) -> dict[str, Any]:
    side = rng.choice([8, 16, 64, 512, 1024, 2048])
    return {"type": "perspective_camera", "id": "p", "resolution": [side, side]}


def race_kwargs(rng: random.Random) -> tuple[dict[str, Any], dict[str, Any]]:
    """A race's keyword arguments, and what must come of them (``expect``)."""
    race: dict[str, Any] = {}
    kwargs: dict[str, Any] = {
        "race": race,
        "cameras": [],
        "sensors": [{"id": "s", "type": "state"}],
    }
    if rng.random() < 0.5:
        kwargs["environment"] = "circuit"
    expect: dict[str, Any] = {}
    if rng.random() < 0.45:
        race["num_agents"] = rng.choice(COUNTS)
    else:
        cars = []
        for i in range(rng.choice([1, 2, 3, 5])):
            car: dict[str, Any] = {"id": rng.choice(IDS)} if rng.random() < 0.8 else {}
            if rng.random() < 0.2:
                car["car"] = {"actions": rng.choice(["continuous", "discrete", "x"])}
            if rng.random() < 0.15:
                car["sensors"] = [perspective(rng)]
            if rng.random() < 0.1:
                car["colour"] = rng.choice(["#ff0000", "red", [0, 0, 999], None])
            cars.append(car)
            if car.get("id") is not None and id_problem(car["id"]) is not None:
                expect.setdefault("refused_at", f"race.cars[{i}].id")
        race["cars"] = cars
    if rng.random() < 0.3:
        race["start"] = rng.choice(["grid", "random", "poses", "x"])
    if rng.random() < 0.2:
        race["poses"] = rng.choice([[[0, 0, 0]], [[True, False, True]], [[NAN, 0, 0]], [[1, 2]],
                                    "x", [[0, 0, 0], [30, 0, 0]]])  # fmt: skip
    for key, values in (("grid_spacing", NUMBERS), ("grid_offset", NUMBERS), ("laps", COUNTS)):
        if rng.random() < 0.25:
            race[key] = rng.choice(values)
    if rng.random() < 0.1:
        race["tile_reward"] = rng.choice(["own", "first", "x"])
    if rng.random() < 0.2:
        kwargs["sensors"] = [perspective(rng)]
    if rng.random() < 0.05:
        race["unknown_key"] = 1
    if _pixels(kwargs) > MAX_CAMERA_PIXELS:
        expect.setdefault("refused_at", "")
    return kwargs, expect


def _pixels(kwargs: dict[str, Any]) -> int:
    """[px] the perspective cameras of every car, as MAX_CAMERA_PIXELS counts them (an
    upper bound of what the env would draw, when the config is valid)."""
    race = kwargs["race"]
    shared = sum(s["resolution"][0] ** 2 for s in kwargs["sensors"] if "resolution" in s)
    cars = race.get("cars")
    if isinstance(cars, list) and cars:
        per = [
            sum(s["resolution"][0] ** 2 for s in car["sensors"]) if "sensors" in car else shared
            for car in cars
        ]
        return sum(per) * PERSPECTIVE_PIXEL_WEIGHT
    count = race.get("num_agents", 1)
    count = count if isinstance(count, int) and not isinstance(count, bool) and count > 0 else 1
    return shared * min(count, 16) * PERSPECTIVE_PIXEL_WEIGHT


# -- per-car actions -----------------------------------------------------------------------------
PEDALS_LOW, PEDALS_HIGH = (-1.0, 0.0, 0.0), (1.0, 1.0, 1.0)


def pedal_action(rng: random.Random) -> Any:
    kind = rng.random()
    if kind < 0.35:  # inside the box, of some dtype
        values = [rng.uniform(lo, hi) for lo, hi in zip(PEDALS_LOW, PEDALS_HIGH, strict=True)]
        return np.array(values, rng.choice([np.float32, np.float64]))
    if kind < 0.6:  # a special number somewhere
        values = [0.0, 0.5, 0.0]
        values[rng.randrange(3)] = rng.choice([NAN, INF, -INF, 1.5, -2.0, 1e308, -0.0])
        with np.errstate(over="ignore"):  # 1e308 is inf as float32
            return np.array(values, np.float32)
    return rng.choice([
        None, "left", {"steer": 0.0}, [0.0, "x", 0.0], [[0.0, 0.0, 0.0]], np.zeros(2),
        np.zeros(4), np.zeros((3, 1)), np.zeros(()), np.array(["a", "b", "c"]),
        np.array([0, 0, 0], object), np.array([1j, 0, 0]), [0.0, 0.5, 0.0], (0.0, 0.5, 0.0),
        np.array([0, 1, 0], np.int64), np.array([True, False, True]), 0.5, b"abc",
    ])  # fmt: skip


def button_action(rng: random.Random) -> Any:
    return rng.choice([
        0, 1, 2, 3, 4, 5, -1, 100, 2**70, 1.0, 1.5, None, True, False, "1", np.int64(3),
        np.int8(-1), np.array(2), np.array([1, 2]), [1], NAN,
    ])  # fmt: skip


def valid_action(car: str, action: Any) -> bool:
    """Whether ``action`` is one of the car's action space (as ``ActionSpec`` reads it)."""
    if car == "buttons":
        if isinstance(action, np.ndarray):
            if action.shape != () or action.dtype.kind not in "iu":
                return False
            action = action.item()
        integral = isinstance(action, (int, np.integer)) and not isinstance(
            action, (bool, np.bool_)
        )
        return integral and 0 <= int(action) < 5
    if isinstance(action, (str, bytes, dict)) or action is None:
        return False
    try:
        array = np.asarray(action)
    except (ValueError, TypeError):
        return False
    if array.shape != (3,) or array.dtype.kind not in "fiu":
        return False
    values = array.astype(np.float64)
    high = np.array(PEDALS_HIGH)
    return bool(np.all(values >= PEDALS_LOW) and np.all(values <= high))


# -- reset options ---------------------------------------------------------------------------------
def reset_options(rng: random.Random) -> tuple[Any, bool]:
    """Options, and whether they must be refused."""
    options = rng.choice([
        None, {}, "x", ["poses"], 3, 1.5, b"x", ("randomize",), {"randomize": True},
        {"randomize": "yes"}, {"randomize": 1}, {"track": 0}, {"track": -1}, {"track": 10**30},
        {"track": "0"}, {"spawn": 0}, {"spawn": 2.5}, {"spawn": None}, {"nosuch": 1}, {1: 2},
        {"poses": [True, False, True]}, {"poses": [[True, False, True], [0, 0, 0]]},
        {"poses": [[NAN, 0, 0], [0, 0, 0]]}, {"poses": [[0, 0, 0]]}, {"poses": "x"},
        {"poses": [["1", "2", "3"], [0, 0, 0]]}, {"poses": None},
    ])  # fmt: skip
    must_refuse = not (options is None or isinstance(options, dict))
    if isinstance(options, dict) and "poses" in options and options["poses"] is not None:
        must_refuse = True  # none of those is two clear finite poses
    return options, must_refuse


# -- opponents -------------------------------------------------------------------------------------
CONTROLS = [(0.0, 0.5, 0.0), [0.1, 0.2, 0.0], np.array([0.0, 1.0, 0.0]), (1e308, 0.0, 0.0),
            0.5, "abc", None, ("a", "b", "c"), (NAN, 0.0, 0.0), (0.0, INF, 0.0),
            (True, 0.0, 0.0), (1.0, 2.0), {"steer": 0}, np.zeros((3, 1))]  # fmt: skip


def valid_controls(value: Any) -> bool:
    items = value.tolist() if isinstance(value, np.ndarray) and value.ndim == 1 else value
    if not isinstance(items, (tuple, list)) or len(items) != 3:
        return False
    return all(
        isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in items
    )


def opponent_specs(rng: random.Random) -> tuple[Any, bool]:
    """Opponent specs, and whether they must be refused."""
    if rng.random() < 0.05:
        return rng.choice(["centerline", {"driver": "centerline"}, [{}] * 16, 7]), True
    specs, refuse = [], False
    for _ in range(rng.choice([0, 1, 1, 2, 3])):
        kind = rng.random()
        if kind < 0.3:
            speed = rng.choice([1.0, 0.5, 2.0, 0, -1, 3, NAN, "x", True, None])
            specs.append({"driver": "centerline", "speed": speed})
            refuse |= not (isinstance(speed, float) and 0 < speed <= 2)
        elif kind < 0.4:
            specs.append(rng.choice([{"driver": "random"}, {"driver": "nosuch"},
                                     {"drivr": "centerline"}, "x", None]))  # fmt: skip
            refuse = True
        else:
            value, follow = rng.choice(CONTROLS), rng.choice([None, 0, 1, 3, 4])
            specs.append({"driver": ("scripted", value, follow)})
            refuse |= not valid_controls(value) or follow in (0, 1)
    return specs, refuse


# -- camera_info files -----------------------------------------------------------------------------
def camera_info(rng: random.Random) -> dict[str, Any]:
    return {
        "image_width": 640,
        "image_height": 480,
        "camera_name": "front",
        "camera_matrix": {
            "rows": 3,
            "cols": 3,
            "data": [500.0, 0, 319.5, 0, 500.0, 239.5, 0, 0, 1],
        },
        "distortion_model": "plumb_bob",
        "distortion_coefficients": {"rows": 1, "cols": 5, "data": [-0.1, 0.01, 0.0, 0.0, 0.0]},
    }


def camera_info_case(rng: random.Random, folder: Path) -> dict[str, Any]:
    info = camera_info(rng)
    damage = rng.choice([
        "none", "none", "number", "missing", "model", "matrix", "text", "binary", "huge",
        "fifo", "folder", "link", "outside", "intrinsics",
    ])  # fmt: skip
    sensor: dict[str, Any] = {"type": "perspective_camera", "id": "p", "resolution": [8, 12],
                              "camera_info": "camera.yaml"}  # fmt: skip
    path = folder / "camera.yaml"
    if damage == "number":
        key = rng.choice(["image_width", "image_height"])
        info[key] = rng.choice([0, -1, 1.5, "640", None, True, 2**70])
    elif damage == "missing":
        del info[rng.choice(list(info))]
    elif damage == "model":
        info["distortion_model"] = rng.choice(["equidistant", None, 5])
    elif damage == "matrix":
        data = list(info["camera_matrix"]["data"])
        data[rng.randrange(9)] = rng.choice([NAN, INF, -500.0, "x", True, 1e12])
        info["camera_matrix"]["data"] = data
    if damage == "text":
        path.write_text(rng.choice(["", "[1, 2]", "x: [", "a: b\nc", "\t:"]))
    elif damage == "binary":
        path.write_bytes(bytes(rng.randrange(256) for _ in range(200)))
    elif damage == "huge":
        path.write_text("# " + "x" * (1 << 20) + "\n" + yaml.safe_dump(info))
    elif damage == "fifo":
        os.mkfifo(path)
    elif damage == "folder":
        path.mkdir()
    elif damage == "link":
        (folder / "real.yaml").write_text(yaml.safe_dump(info))
        path.symlink_to(folder / "real.yaml")
    elif damage == "outside":
        sensor["camera_info"] = rng.choice(["../camera.yaml", "/etc/passwd", "/dev/zero"])
    elif damage == "intrinsics":
        del sensor["camera_info"]
        sensor["intrinsics"] = rng.choice([
            [1e12, 1e12, 5.5, 3.5], [NAN, 1, 5, 3], [1, 1, 5], [0, 1, 5, 3], ["a", 1, 5, 3],
            [1e16, 1, 1, 1],
        ])  # fmt: skip
    else:
        path.write_text(yaml.safe_dump(info))
    config = {"cameras": [], "sensors": [sensor], "race": {"num_agents": rng.choice([1, 2])}}
    (folder / "env.yaml").write_text(yaml.safe_dump(config))
    return {"config": str(folder / "env.yaml")}


# -- the cache folder ------------------------------------------------------------------------------
def cache_folder_case(rng: random.Random, folder: Path) -> tuple[dict[str, Any], set[str]]:
    """A cache folder with hostile neighbours of the entry the case builds; returns the
    case's arguments and the files (relative to ``folder``) that the cache wrote or may
    write: its entry, its lock file and the folder key, when they are the cache's own."""
    root = folder / "cache"
    root.mkdir()
    outside = folder / "outside.bin"
    outside.write_bytes(b"the user's own file")
    key = f"k{rng.randrange(10**6)}"
    name = cache.digest((cache.VERSION, key))
    entry, lock = root / f"{name}{disk.SUFFIX}", root / f"{name}{disk.LOCK_SUFFIX}"
    at_entry = rng.choice(["none", "none", "fifo", "link", "folder", "user", "empty", "stale"])
    if at_entry == "fifo":
        os.mkfifo(entry)
    elif at_entry == "link":
        entry.symlink_to(outside)
    elif at_entry == "folder":
        entry.mkdir()
    elif at_entry == "user":
        entry.write_bytes(b"my notes, not a cache file")
    elif at_entry == "empty":
        entry.write_bytes(b"")
    elif at_entry == "stale":  # the cache's own format, under another folder key
        data = disk.Entry({"values": {"array": "values"}, "scale": 1.5}, {"values": np.zeros(9)})
        disk.write(root, name, cache.VERSION, data)
        (root / disk.KEY_FILE).write_bytes(secrets.token_bytes(disk.KEY_BYTES))
    at_lock = rng.choice(["none", "none", "fifo", "user", "digits", "link"])
    if at_lock == "fifo":
        os.mkfifo(lock)
    elif at_lock == "user":
        lock.write_text("my lock notes")
    elif at_lock == "digits":
        lock.write_text("12345\n")
    elif at_lock == "link":
        lock.symlink_to(outside)
    user_key = rng.random() < 0.15 and at_entry != "stale"
    if user_key:
        key_kind = rng.choice(["fifo", "folder", "short"])
        key_file = root / disk.KEY_FILE
        if key_kind == "fifo":
            os.mkfifo(key_file)
        elif key_kind == "folder":
            key_file.mkdir()
        else:
            key_file.write_bytes(b"short")
    for user in ("package.lock", "weights.npc", "notes.txt", "a" * 64 + ".npc",
                 ".tmp-abcdefgh.npc", "b" * 64 + ".lock"):  # fmt: skip
        if rng.random() < 0.5:
            (root / user).write_bytes(f"{user}: the user's".encode())
    if rng.random() < 0.3:
        (root / ("c" * 64 + ".npc")).symlink_to(outside)
    mine = {f"cache/{disk.KEY_FILE}"} if not user_key else set()
    if at_entry in ("none", "empty", "stale"):  # the cache's own (or nothing, or no bytes)
        mine.add(f"cache/{entry.name}")
    if at_lock in ("none", "digits"):  # a lock file holding a process id: the cache's own
        mine.add(f"cache/{lock.name}")
    return {"folder": str(root), "key": key, "clear": rng.random() < 0.5}, mine


def specials(folder: Path) -> dict[str, str]:
    """The FIFOs, links and folders under ``folder``: what the cache must leave alone."""
    found = {}
    for path in sorted(folder.rglob("*")):
        rel = str(path.relative_to(folder))
        if path.is_symlink():
            found[rel] = "link"
        elif path.is_fifo():
            found[rel] = "fifo"
    return found


# -- the campaign ----------------------------------------------------------------------------------
def problems_are_clear(outcome: dict[str, Any]) -> bool:
    """Every problem names where (a source) and says what it got and what is allowed."""
    problems = outcome.get("make") or []
    return bool(problems) and all(
        src and "got" in text and "; " in text for src, _, text in problems
    )


class Tally:
    def __init__(self, campaign: Campaign):
        self.campaign = campaign
        self.failures: list[str] = []

    def fail(self, kind: str, case: Any, outcome: dict[str, Any], why: str) -> None:
        if len(self.failures) < 20:
            self.failures.append(f"{kind}: {why}: {case!r:.300} -> {outcome!r:.600}")

    def settle(self, kind: str, case: Any, outcome: dict[str, Any]) -> None:
        """The outcomes every kind shares: a crash, hang or bad observation fails."""
        if outcome["outcome"] not in ("ok", "config_error", "invalid_action"):
            self.fail(kind, case, outcome, "neither a clear error nor a working env")
        elif outcome["outcome"] == "config_error" and not problems_are_clear(outcome):
            self.fail(kind, case, outcome, "an unclear ConfigError")


def run_batches(campaign: Campaign, tally: Tally, kind: str, cases: list[tuple[Any, ...]],
                check) -> None:  # fmt: skip
    """Run ``cases`` ((case dict, extra) pairs) two at a time; ``check(extra, outcome)``."""
    for start in range(0, len(cases), 2):
        batch = cases[start : start + 2]
        outcomes = campaign.run(kind, [case for case, _ in batch])
        for (case, extra), outcome in zip(batch, outcomes, strict=True):
            tally.settle(kind, case, outcome)
            why = check(extra, outcome)
            if why:
                tally.fail(kind, case, outcome, why)


def race_config_cases(campaign: Campaign, tally: Tally, rng: random.Random) -> None:
    cases = []
    for _ in range(CASES["race_config"] * SCALE):
        kwargs, expect = race_kwargs(rng)
        cases.append(({"kind": "race_config", "args": {"kwargs": kwargs}}, expect))

    def check(expect: dict[str, Any], outcome: dict[str, Any]) -> str | None:
        if "refused_at" not in expect:
            return None
        if outcome["outcome"] != "config_error":
            return "accepted a config it must refuse"
        paths = [path for _, path, _ in outcome["make"]]
        named = any(expect["refused_at"] in p for p in paths)
        if not named and all(".id" in p for p in paths):  # (another problem may come first)
            return f"refused without naming {expect['refused_at']}"
        return None

    run_batches(campaign, tally, "race_config", cases, check)


def action_cases(campaign: Campaign, tally: Tally, rng: random.Random) -> None:
    cases = []
    for _ in range(CASES["action"] * SCALE):
        car = rng.choice(["pedals", "buttons"])
        action = pedal_action(rng) if car == "pedals" else button_action(rng)
        form = rng.choice(["parallel", "aec"])
        case = {"kind": "action", "args": {"form": form, "car": car, "action": action}}
        cases.append((case, (car, valid_action(car, action))))

    def check(extra: tuple[str, bool], outcome: dict[str, Any]) -> str | None:
        car, valid = extra
        if outcome["outcome"] == "invalid_action" and f"car '{car}'" not in outcome["error"]:
            return "the error does not name the car"
        if valid and outcome["outcome"] != "ok":
            return "a valid action refused"
        if not valid and outcome["outcome"] == "ok":
            return "an invalid action accepted"
        return None

    run_batches(campaign, tally, "action", cases, check)


def reset_cases(campaign: Campaign, tally: Tally, rng: random.Random) -> None:
    cases = []
    for _ in range(CASES["reset"] * SCALE):
        options, refuse = reset_options(rng)
        form = rng.choice(["parallel", "aec"])
        cases.append(({"kind": "reset", "args": {"form": form, "options": options}}, refuse))

    def check(refuse: bool, outcome: dict[str, Any]) -> str | None:
        if refuse and outcome["outcome"] != "config_error":
            return "accepted options it must refuse"
        sources = {src for src, _, _ in outcome.get("make") or []}
        if outcome["outcome"] == "config_error" and sources != {"<reset options>"}:
            return "a refusal that does not name the reset options"
        return None

    run_batches(campaign, tally, "reset", cases, check)


def opponents_cases(campaign: Campaign, tally: Tally, rng: random.Random) -> None:
    cases = []
    for _ in range(CASES["opponents"] * SCALE):
        specs, refuse = opponent_specs(rng)
        track = rng.choice([None, "circuit"])
        cases.append(({"kind": "opponents", "args": {"track": track, "specs": specs}}, refuse))

    def check(refuse: bool, outcome: dict[str, Any]) -> str | None:
        if refuse and outcome["outcome"] != "config_error":
            return "accepted opponents it must refuse"
        if not refuse and outcome["outcome"] != "ok":
            return "refused valid opponents"
        paths = [path for _, path, _ in outcome.get("make") or []]
        if outcome["outcome"] == "config_error" and not all(
            p.startswith("opponents") for p in paths
        ):
            return "a refusal that does not name the opponent"
        return None

    run_batches(campaign, tally, "opponents", cases, check)


def file_cases(campaign: Campaign, tally: Tally, rng: random.Random, kind: str) -> None:
    """camera_info and cache cases: files made here, their bytes checked after each case."""
    for _ in range(0, CASES[kind] * SCALE, 2):
        batch = []
        for _ in range(2):
            folder = campaign.folder()
            if kind == "camera_info":
                case = {"kind": "race_config", "args": {"kwargs": camera_info_case(rng, folder)}}
                may_change: set[str] = set()
            else:
                args, may_change = cache_folder_case(rng, folder)
                case = {"kind": "cache", "args": args}
            before = {k: v for k, v in digests(folder).items() if k not in may_change}
            batch.append((case, (folder, before, specials(folder))))
        outcomes = campaign.run(kind, [case for case, _ in batch])
        for (case, (folder, before, kept)), outcome in zip(batch, outcomes, strict=True):
            tally.settle(kind, case, outcome)
            if not unchanged(before, digests(folder)):
                tally.fail(kind, case, outcome, "an input file changed or vanished")
            if specials(folder) != kept:
                tally.fail(kind, case, outcome, "a FIFO or link was removed or replaced")
            if kind == "cache" and outcome["outcome"] != "ok":
                tally.fail(kind, case, outcome, "the cache did not give the value")
            if kind == "camera_info" and outcome["outcome"] == "config_error":
                named = " ".join(f"{src} {path}" for src, path, _ in outcome["make"])
                if "sensors[0]" not in named and "camera" not in named:
                    tally.fail(kind, case, outcome, "a refusal that names neither key nor file")
            shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture
def campaign():
    root = Path(tempfile.mkdtemp(prefix="tinyrace-hostile4-"))
    runner = Campaign(root, SECONDS)
    yield runner
    runner.close()
    shutil.rmtree(root, ignore_errors=True)


def children(pid: int) -> list[int]:
    """The live processes whose parent is ``pid`` (Linux's /proc; [] elsewhere)."""
    found = []
    for entry in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = entry.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid and fields[0] != "Z":
            found.append(int(entry.parent.name))
    return found


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def test_hostile_round4_campaign(campaign: Campaign, capsys):
    rng = random.Random(SEED)
    tally = Tally(campaign)
    seconds = {}
    for kind, run in (
        ("race_config", lambda: race_config_cases(campaign, tally, rng)),
        ("action", lambda: action_cases(campaign, tally, rng)),
        ("reset", lambda: reset_cases(campaign, tally, rng)),
        ("opponents", lambda: opponents_cases(campaign, tally, rng)),
        ("camera_info", lambda: file_cases(campaign, tally, rng, "camera_info")),
        ("cache", lambda: file_cases(campaign, tally, rng, "cache")),
    ):
        start = time.perf_counter()
        run()
        seconds[kind] = round(time.perf_counter() - start, 1)
    workers = [w.process.pid for w in campaign.workers]
    started = workers + [child for pid in workers for child in children(pid)]
    campaign.close()
    total = sum(campaign.counts.values())
    outcomes = collections.Counter(campaign.outcomes)
    with capsys.disabled():
        counts = dict(campaign.counts)
        print(f"\nhostile round 4 campaign: {total} cases {counts}; {dict(outcomes)}")
        print(f"seconds per kind: {seconds}")
    assert not tally.failures, "\n".join(tally.failures)
    assert total >= MIN_CASES
    left = [pid for pid in started if alive(pid)]
    assert not left, f"processes left behind: {left}"
    for kind in ("race_config", "action", "reset", "opponents", "camera_info"):
        assert outcomes[f"{kind} ok"] > 0, outcomes  # not refusals only
        assert any(k.startswith(kind) and "ok" not in k for k in outcomes), outcomes
