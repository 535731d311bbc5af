"""Issue 12.7: a campaign of generated hostile inputs (YAML text, images, CLI argv, reset options).

Each case runs in one of a few long-lived worker processes (tests/hostile_worker.py) under an
address-space limit and a per-case alarm; a worker that dies or hangs is restarted and its case
fails. Every case must end in a clear error (a ConfigError naming the file or key, or a
``tinyrace`` exit code without a traceback) or a working env, and no input file's bytes may
change. Hypothesis is derandomised when ``CI`` is set, free elsewhere. The number of cases run
is printed.
"""

from __future__ import annotations

import collections
import contextlib
import hashlib
import itertools
import os
import pickle
import select
import shutil
import struct
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import cv2
import hostile_worker
import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import tinyrace
from tinyrace.config.yaml_file import MAX_YAML_BYTES
from tinyrace.env_checks import RESET_OPTIONS

WORKER = Path(__file__).with_name("hostile_worker.py")
MEMORY = 2 << 30  # [bytes] address space of a worker (its imports take about 300 MiB)
SECONDS = 10  # [s] of CPU time, all threads, each case ends within (3x that of wall time)
WORKERS = 2
IN_CI = bool(os.environ.get("CI"))
CAMPAIGN = {  # hypothesis examples per kind; each example is a batch of WORKERS cases
    "yaml": 160,
    "image": 130,
    "argv": 100,
    "options": 140,
}
MIN_CASES = 1000


def _settings(examples: int):
    return settings(
        max_examples=examples,
        derandomize=IN_CI,
        database=None,
        deadline=None,
        suppress_health_check=list(HealthCheck),
        print_blob=True,
    )


# -- workers -----------------------------------------------------------------------------------
class Worker:
    """One worker process; restarted after a case that killed, hung or broke it."""

    def __init__(self, seconds: int = SECONDS) -> None:
        self.process: subprocess.Popen | None = None
        self.restarts = -1
        self.seconds = seconds
        self._start()

    def _start(self) -> None:
        self.stop()
        here = Path(tinyrace.__file__).resolve().parents[1]  # the tinyrace this test imported
        env = {**os.environ, "PYTHONPATH": f"{here}{os.pathsep}{WORKER.parent}"}
        env.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", PYTHONUNBUFFERED="1")
        for name in ("SDL_VIDEODRIVER", "DISPLAY", "WAYLAND_DISPLAY"):  # `play` opens no window
            env.pop(name, None)  # (.ci/run exports SDL's dummy driver, which would play on)
        self.process = subprocess.Popen(
            [sys.executable, str(WORKER), str(MEMORY), str(self.seconds)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,  # OpenCV's warnings about broken files
            env=env,
        )
        self.restarts += 1
        assert self._receive(120) == {"ready": True}

    def send(self, case: dict[str, Any]) -> None:
        data = pickle.dumps(case)
        self.process.stdin.write(struct.pack(">I", len(data)) + data)
        self.process.stdin.flush()

    def receive(self) -> dict[str, Any]:
        """The case's outcome; 'died' or 'hung' when the worker gave none."""
        # the alarms cannot stop a long C call
        outcome = self._receive(self.seconds * hostile_worker.WALL_FACTOR + 20)
        if outcome is None:
            try:
                self.process.wait(timeout=2)  # it closed its pipe: it is exiting
                hung = False
            except subprocess.TimeoutExpired:
                hung = True
            self._start()
            return {"outcome": "hung" if hung else "died"}
        if outcome["outcome"] in ("timeout", "memory", "crash"):
            self._start()  # its state after an interrupted case is not to be trusted
        return outcome

    def _receive(self, timeout: float) -> Any:
        head = self._read_exactly(4, timeout)
        if head is None:
            return None
        body = self._read_exactly(struct.unpack(">I", head)[0], timeout)
        return None if body is None else pickle.loads(body)

    def _read_exactly(self, size: int, timeout: float) -> bytes | None:
        fd, data = self.process.stdout.fileno(), b""
        while len(data) < size:
            ready, _, _ = select.select([fd], [], [], timeout)
            chunk = os.read(fd, size - len(data)) if ready else b""
            if not chunk:
                return None
            data += chunk
        return data

    def stop(self) -> None:
        if self.process is None:
            return
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()
        # Closed now, the pipes cannot warn "unclosed file" whenever the garbage collector
        # next meets the old Popen (which may be inside another test's warnings check).
        for pipe in (self.process.stdin, self.process.stdout):
            with contextlib.suppress(OSError):  # a worker that died mid-case broke its pipe
                pipe.close()


class Campaign:
    """The workers, a scratch folder per case, and the tally of what was run."""

    def __init__(self, root: Path, seconds: int = SECONDS):
        self.root = root
        self.workers = [Worker(seconds) for _ in range(WORKERS)]
        self.counts: collections.Counter[str] = collections.Counter()
        self.outcomes: collections.Counter[str] = collections.Counter()
        self._next = 0

    def folder(self) -> Path:
        self._next += 1
        path = self.root / f"case_{self._next}"
        path.mkdir()
        return path

    def run(self, kind: str, cases: list[dict[str, Any]]) -> list[dict[str, Any]]:
        """Run ``cases`` side by side, one per worker."""
        for worker, case in zip(self.workers, cases, strict=False):
            worker.send(case)
        outcomes = [worker.receive() for worker, _ in zip(self.workers, cases, strict=False)]
        self.counts[kind] += len(cases)
        self.outcomes.update(f"{kind} {o['outcome']} {o.get('code', '')}".strip() for o in outcomes)
        return outcomes

    def close(self) -> None:
        for worker in self.workers:
            worker.stop()


def digests(folder: Path) -> dict[str, str]:
    """sha256 of every regular file under ``folder`` (FIFOs and devices are not read)."""
    found = {}
    for path in sorted(folder.rglob("*")):
        if path.is_file() and not path.is_symlink():
            found[str(path.relative_to(folder))] = hashlib.sha256(path.read_bytes()).hexdigest()
    return found


def unchanged(before: dict[str, str], after: dict[str, str]) -> bool:
    return all(after.get(name) == digest for name, digest in before.items())


# -- a valid track folder to start from ---------------------------------------------------------
CAMERA = {"id": "front", "resolution": [12, 16], "roi": [40, 50]}
WHITE, BLUE, RED = [255, 255, 255], [255, 0, 0], [0, 0, 255]
BASE = {
    "sim": {"fps": 30, "step_limit": 50},
    "car": {"wheelbase": 20, "track_width": 12, "velocity": 60},
    "cameras": [CAMERA],
    "reward_design": {
        "color_obstacles": [{"color": BLUE, "reward": -1}, {"color": RED, "reward": "done"}],
        "cross_track_error": {"use_cte": True, "trajectory_color": WHITE, "shaping": "linear"},
    },
    "tracks": [{"image": "t.png", "spawns": [[40.0, 75.0, 0.0]]}],
}
BASE_TEXT = yaml.safe_dump(BASE, sort_keys=False)


def base_image() -> np.ndarray:
    image = np.zeros((150, 200, 3), np.uint8)
    image[74:77, :] = 255  # the trajectory
    image[20:30, 100:110] = BLUE
    image[120:130, 150:160] = RED
    return image


def encoded(image: np.ndarray, ext: str) -> bytes:
    ok, data = cv2.imencode(ext, image)
    assert ok
    return data.tobytes()


BASE_PNG = encoded(base_image(), ".png")


def write_track(folder: Path, text: bytes | str, image: bytes = BASE_PNG, name="t.png") -> None:
    (folder / "track.yaml").write_bytes(text.encode() if isinstance(text, str) else text)
    (folder / name).write_bytes(image)


# -- YAML text ---------------------------------------------------------------------------------
HOSTILE_SCALARS = [
    "1e400", "-1e400", ".nan", ".inf", "9" * 5000, "9" * 400, "-" + "9" * 40, "0x" + "f" * 40,
    "2001-13-45", "2001-12-14t21:59:43.10-05:00", "!!binary AAAA", "~", "''", "[]", "{}",
    "!!set {a, b}", "0o777", "1_000_000_000_000", "true", "'" + "x" * 3000 + "'",
]  # fmt: skip
KNOBS = [
    ("sim", "fps"), ("sim", "step_limit"), ("sim", "overview_downscale"), ("car", "wheelbase"),
    ("car", "velocity"), ("car", "max_steering_change"), ("reward_design", "time_penalty"),
]  # fmt: skip
YAML_DAMAGE = [
    "\t", ": :", "{", "]", "- - -", "&a *b", "*a", "&a", "key: [1, 2", "!!python/object:os.system",
    "\x00", "'", '"', "? ", "%YAML 9.9\n", "--- ", "\n  bad: 1\n", "<<: *a", "\xff", "\ufeff",
]  # fmt: skip


@st.composite
def alias_bomb(draw) -> str:
    levels = draw(st.integers(1, 9))
    width = draw(st.integers(1, 12))
    names = [f"l{i}" for i in range(levels)]
    lines = [f"{names[0]}: &{names[0]} [{', '.join(['x'] * width)}]"]
    for prev, name in itertools.pairwise(names):
        lines.append(f"{name}: &{name} [{', '.join([f'*{prev}'] * width)}]")
    lines.append(f"sim: *{names[-1]}" if draw(st.booleans()) else "")
    return "\n".join(lines) + "\n"


@st.composite
def deep_nesting(draw) -> str:
    depth = draw(st.one_of(st.integers(1, 80), st.sampled_from([1000, 100_000])))
    style = draw(st.sampled_from(["flow_list", "flow_map", "block_map", "block_list"]))
    if style == "flow_list":
        return "sim: " + "[" * depth + "]" * depth + "\n"
    if style == "flow_map":
        return "sim: " + "{a: " * depth + "1" + "}" * depth + "\n"
    if style == "block_map":
        return "".join("  " * i + "a:\n" for i in range(min(depth, 2000))) + "  " * depth + "1\n"
    return "".join("  " * i + "-\n" for i in range(min(depth, 2000)))


@st.composite
def duplicate_keys(draw) -> str:
    section, key = draw(st.sampled_from(KNOBS))
    where = draw(st.sampled_from(["top", "inner"]))
    if where == "top":
        return BASE_TEXT + f"{section}: {{{key}: 1}}\n"
    return BASE_TEXT.replace(f"{section}:\n", f"{section}:\n  {key}: 1\n  {key}: 2\n", 1)


@st.composite
def huge_numbers(draw) -> str:
    config = yaml.safe_load(BASE_TEXT)
    for _ in range(draw(st.integers(1, 3))):
        section, key = draw(st.sampled_from(KNOBS))
        config[section][key] = f"@@{draw(st.sampled_from(HOSTILE_SCALARS))}@@"
    text = yaml.safe_dump(config, sort_keys=False, width=10**6)
    return text.replace("'@@", "").replace("@@'", "")


@st.composite
def damaged_text(draw) -> str:
    text = BASE_TEXT
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(text)))
        text = text[:at] + draw(st.sampled_from(YAML_DAMAGE)) + text[at:]
    return text


@st.composite
def benign_text(draw) -> str | bytes:
    """The same config written differently: it must load as the base does."""
    form = draw(st.sampled_from(["crlf", "bom", "flow", "merge", "anchor", "comments"]))
    if form == "crlf":
        return BASE_TEXT.replace("\n", "\r\n")
    if form == "bom":
        return b"\xef\xbb\xbf" + BASE_TEXT.encode()
    if form == "flow":
        return yaml.safe_dump(BASE, default_flow_style=True, width=draw(st.integers(20, 200)))
    if form == "merge":
        return BASE_TEXT.replace("car:\n", "car:\n  <<: {wheelbase: 5, velocity: 60}\n", 1)
    if form == "anchor":
        return BASE_TEXT.replace("sim:\n", "sim: &s\n", 1)
    return "".join(f"{line}  # note\n" if line.strip() else "\n" for line in BASE_TEXT.split("\n"))


YAML_TEXT = st.one_of(
    benign_text(),
    alias_bomb(),
    deep_nesting(),
    duplicate_keys(),
    huge_numbers(),
    damaged_text(),
    st.binary(max_size=600).map(lambda b: BASE_TEXT.encode()[:200] + b),
    st.binary(max_size=300),
    st.just(BASE_TEXT + "#" * MAX_YAML_BYTES),
    st.sampled_from(["fifo", "dev_zero", "folder", "symlink_loop", "empty"]),
)


def write_yaml_case(folder: Path, text: str | bytes) -> None:
    (folder / "t.png").write_bytes(BASE_PNG)
    special = folder / "track.yaml"
    if text == "fifo":
        os.mkfifo(special)
    elif text == "dev_zero":
        os.symlink("/dev/zero", special)
    elif text == "folder":
        special.mkdir()
    elif text == "symlink_loop":
        os.symlink("track.yaml", special)
    elif text == "empty":
        special.write_bytes(b"")
    else:
        write_track(folder, text)


# -- images ------------------------------------------------------------------------------------
@st.composite
def valid_image(draw) -> tuple[str, bytes]:
    side = st.integers(1, 300) if draw(st.booleans()) else st.integers(160, 300)  # holds spawns
    height, width = draw(side), draw(side)
    channels = draw(st.sampled_from([1, 3, 4]))
    ext = draw(st.sampled_from([".png", ".jpg", ".pgm"]))
    dtype = np.uint16 if ext == ".png" and draw(st.booleans()) else np.uint8
    if ext == ".pgm":
        channels = 1
    if ext == ".jpg" and channels == 4:
        channels = 3
    shape = (height, width) if channels == 1 else (height, width, channels)
    image = np.zeros(shape, dtype)
    top = np.iinfo(dtype).max
    image[: height // 2] = top
    if channels >= 3 and height >= 10 and width >= 20:  # the obstacle colours, off the spawn
        for color, columns in ((BLUE, slice(2, 8)), (RED, slice(12, 18))):
            image[2:8, columns, :3] = np.array(color) // 255 * top
    return ext, encoded(image, ext)


def _with_png_header(data: bytes, width: int, height: int) -> bytes:
    return data[:16] + struct.pack(">II", width, height) + data[24:]


def _with_jpeg_frame(data: bytes, width: int, height: int, channels: int) -> bytes:
    sof = data.find(b"\xff\xc0")
    if sof < 0:
        return data
    frame = struct.pack(">HHB", height, width, channels)
    return data[: sof + 5] + frame + data[sof + 10 :]


@st.composite
def hostile_image(draw) -> tuple[str, bytes]:
    ext, data = draw(valid_image())
    damage = draw(
        st.sampled_from(["none", "header", "truncate", "flip", "garbage", "text", "pgm_header"])
    )
    size = st.integers(0, 2**32 - 1) | st.sampled_from([0, 1, 6000, 65535, 100_000])
    if damage == "header" and ext == ".png":
        data = _with_png_header(data, draw(size), draw(size))
    elif damage == "header" and ext == ".jpg":
        dims = st.integers(0, 65535)
        data = _with_jpeg_frame(data, draw(dims), draw(dims), draw(st.integers(0, 255)))
    elif damage == "truncate":
        data = data[: draw(st.integers(0, len(data)))]
    elif damage == "flip":
        data = bytearray(data)
        for _ in range(draw(st.integers(1, 8))):
            data[draw(st.integers(0, len(data) - 1))] ^= draw(st.integers(1, 255))
        data = bytes(data)
    elif damage == "garbage":
        data = draw(st.binary(max_size=500))
    elif damage == "text":
        data = draw(st.sampled_from([BASE_TEXT.encode(), b"x,y\n1,2\n", b"", b"P5\n"]))
    elif damage == "pgm_header":
        numbers = st.integers(-5, 2**40) | st.sampled_from([0, 1, 255, 65535, 65536])
        head = f"P5\n{draw(numbers)} {draw(numbers)}\n{draw(numbers)}\n".encode()
        data = head + draw(st.binary(max_size=200))
    return ext, data


@st.composite
def image_config(draw) -> str:
    config = yaml.safe_load(BASE_TEXT)
    if draw(st.integers(0, 2)) == 0:  # no obstacles: a grey picture can hold no colour
        del config["reward_design"]["color_obstacles"]
    if draw(st.integers(0, 3)) == 0:
        config["files"] = {"max_image_pixels": draw(st.integers(1, 400_000_000))}
    if draw(st.integers(0, 5)) == 0:  # a black plane instead of the image
        side = st.integers(16, 20000)
        config["tracks"] = [{"plane_size": [draw(side), draw(side)], "spawns": [[40, 75, 0]]}]
        if draw(st.booleans()):  # a plane has no obstacle pixels (refused colours), or none
            config["reward_design"].pop("color_obstacles", None)
    return yaml.safe_dump(config, sort_keys=False)


# -- command lines -----------------------------------------------------------------------------
EXPERIMENT = {
    "env": {"environment": "."},
    "driver": "centerline",
    "episodes": 1,
    "max_steps": 3,
    "output": {"video": False},
}


def argv_folder(folder: Path) -> None:
    """A track folder with an experiment, a FIFO, a subfolder and a file the user made."""
    write_track(folder, BASE_TEXT)
    (folder / "exp.yaml").write_text(yaml.safe_dump(EXPERIMENT))
    (folder / "mine.png").write_bytes(b"the user's own file")
    os.mkfifo(folder / "fifo.yaml")
    (folder / "sub").mkdir()


PATHS = [
    ".", "track.yaml", "t.png", "exp.yaml", "fifo.yaml", "sub", "/dev/zero", "/dev/null",
    "procedural", "nonexistent", "", "x" * 5000, "a\x00b", "../", "sub/../track.yaml",
]  # fmt: skip
OUTPUTS = [
    "t.png", "track.yaml", "mine.png", "new.png", "sub/new.png", "sub", ".", "/dev/null",
    "fifo.yaml", "deep/er/new.png", "x" * 5000, "new.txt",
]  # fmt: skip
NUMBERS = st.integers(-(2**70), 2**70).map(str) | st.sampled_from(["0", "-1", "1e3", "x", ""])


@st.composite
def command_line(draw) -> list[str]:
    commands = ["validate", "show", "show", "run", "play", "report", "examples", "garbage"]
    command = draw(st.sampled_from(commands))
    if command == "validate":
        return ["validate", draw(st.sampled_from(PATHS))]
    if command == "show":
        argv = ["show", draw(st.sampled_from(PATHS))]
        if draw(st.booleans()):
            argv += ["-o", draw(st.sampled_from(OUTPUTS))]
        if draw(st.booleans()):
            argv += ["--seed", draw(NUMBERS)]
        if draw(st.booleans()):
            argv.append("--force")
        return argv
    if command == "run":
        experiment = draw(st.sampled_from(["exp.yaml", "exp.yaml", "track.yaml", "fifo.yaml"]))
        argv = ["run", experiment, "--no-video", "--quiet"]
        argv += ["--episodes", draw(st.sampled_from(["1", "0", "-3", "x", "1e9"]))]
        return [*argv, "--out", draw(st.sampled_from(["out", "mine.png", "/dev/null"]))]
    if command in ("play", "report"):
        return [command, draw(st.sampled_from(PATHS))]
    if command == "examples":
        name = draw(st.sampled_from(["formula_student", "carracing", "nope", ""]))
        return ["examples", "copy", name, draw(st.sampled_from(PATHS + OUTPUTS))]
    return draw(st.lists(st.text(max_size=20), max_size=4))


# -- reset options -----------------------------------------------------------------------------
ANY_VALUE = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=20),
    st.binary(max_size=10),
    st.lists(st.integers(-3, 3), max_size=3),
    st.builds(np.array, st.lists(st.integers(-3, 3), max_size=3)),
    st.sampled_from([np.int64(0), np.bool_(True), np.float32(0.0), np.uint8(1)]),
)
OPTIONS = st.one_of(
    st.none(),
    st.dictionaries(
        st.sampled_from(RESET_OPTIONS) | st.text(max_size=8) | st.integers(), ANY_VALUE, max_size=3
    ),
    ANY_VALUE,
)


# -- the campaign ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def campaign():
    root = Path(tempfile.mkdtemp(prefix="tinyrace-hostile-"))
    running = Campaign(root)
    yield running
    running.close()
    shutil.rmtree(root, ignore_errors=True)


@pytest.mark.parametrize(
    "action, outcome",
    [("allocate", "memory"), ("sleep", "timeout"), ("spin", "timeout"), ("die", "died")],
)
def test_the_workers_report_memory_hangs_and_deaths(campaign: Campaign, action, outcome):
    worker = campaign.workers[0]
    restarts = worker.restarts
    worker.send({"kind": "probe", "args": {"action": action}})
    assert worker.receive()["outcome"] == outcome
    assert worker.restarts == restarts + 1  # a fresh worker for the next case
    worker.send({"kind": "probe", "args": {"action": "nothing"}})
    assert worker.receive() == {"outcome": "ok"}


def check_config_outcome(outcome: dict[str, Any], folder: Path) -> None:
    """validate and gym.make agree; every problem names a file of the case."""
    assert outcome["outcome"] in ("ok", "config_error"), outcome
    if outcome["outcome"] == "ok":
        assert outcome["validate"] == [], outcome  # validate refused what runs
        return
    assert outcome["validate"], outcome  # validate accepted what does not run
    for source, _path, text in outcome["make"]:
        assert source.startswith(str(folder)), text  # the file the problem is in
        assert len(text) < 2000, text  # values are quoted shortened


@pytest.mark.slow  # over a thousand cases in worker processes: CI runs it (-m slow)
def test_hostile_campaign(campaign: Campaign, capsys):
    restarts_before = sum(w.restarts for w in campaign.workers)
    run_yaml(campaign)
    run_images(campaign)
    run_argv(campaign)
    run_options(campaign)
    total = sum(campaign.counts.values())
    restarts = sum(w.restarts for w in campaign.workers) - restarts_before
    summary = ", ".join(f"{kind} {n}" for kind, n in campaign.counts.items())
    with capsys.disabled():
        print(
            f"\nhostile campaign: {total} cases ({summary}); outcomes {dict(campaign.outcomes)}; "
            f"worker restarts {restarts}; derandomized {IN_CI}"
        )
    assert total >= MIN_CASES
    for kind in ("yaml", "image", "options"):  # not a campaign of refusals only
        assert campaign.outcomes[f"{kind} ok"] > 0, campaign.outcomes


def _config_cases(campaign: Campaign, kind: str, writers: list) -> None:
    folders = []
    for write in writers:
        folder = campaign.folder()
        write(folder)
        folders.append(folder)
    before = [digests(f) for f in folders]
    cases = [{"kind": "config", "args": {"folder": str(f)}} for f in folders]
    for folder, old, outcome in zip(folders, before, campaign.run(kind, cases), strict=True):
        check_config_outcome(outcome, folder)
        assert unchanged(old, digests(folder)), "an input file changed"
        shutil.rmtree(folder)


def run_yaml(campaign: Campaign) -> None:
    @_settings(CAMPAIGN["yaml"])
    @given(texts=st.lists(YAML_TEXT, min_size=WORKERS, max_size=WORKERS))
    def check(texts):
        _config_cases(campaign, "yaml", [lambda f, t=t: write_yaml_case(f, t) for t in texts])

    check()


def run_images(campaign: Campaign) -> None:
    @_settings(CAMPAIGN["image"])
    @given(
        images=st.lists(hostile_image(), min_size=WORKERS, max_size=WORKERS),
        configs=st.lists(image_config(), min_size=WORKERS, max_size=WORKERS),
    )
    def check(images, configs):
        writers = []
        for (ext, data), config in zip(images, configs, strict=True):
            text = config.replace("t.png", f"t{ext}")
            writers.append(lambda f, t=text, d=data, e=ext: write_track(f, t, d, f"t{e}"))
        _config_cases(campaign, "image", writers)

    check()


def run_argv(campaign: Campaign) -> None:
    @_settings(CAMPAIGN["argv"])
    @given(argvs=st.lists(command_line(), min_size=WORKERS, max_size=WORKERS))
    def check(argvs):
        folders = [campaign.folder() for _ in argvs]
        for folder in folders:
            argv_folder(folder)
        before = [digests(f) for f in folders]
        cases = [
            {"kind": "argv", "args": {"argv": argv, "cwd": str(f)}}
            for argv, f in zip(argvs, folders, strict=True)
        ]
        outcomes = campaign.run("argv", cases)
        for argv, folder, old, outcome in zip(argvs, folders, before, outcomes, strict=True):
            assert outcome["outcome"] == "exit", (argv, outcome)
            assert isinstance(outcome["code"], int), (argv, outcome)
            assert "Traceback" not in outcome["stderr"], (argv, outcome)
            if outcome["code"] == 1:  # 1 is validate's "problems found", else an internal error
                assert argv[:1] == ["validate"], (argv, outcome)
            if outcome["code"] != 0:
                assert (outcome["stderr"] + outcome["stdout"]).strip(), (argv, outcome)  # why
            after = digests(folder)
            replaced = _forced_output(argv)  # the one file the user asked to replace
            kept = {name: digest for name, digest in old.items() if name != replaced}
            assert unchanged(kept, after), (argv, "an input file changed")
            if argv[:1] in (["show"], ["report"], ["validate"]) and "--force" not in argv:
                assert set(after) == set(old), (argv, "it wrote into a track folder")
            shutil.rmtree(folder)

    check()


def _forced_output(argv: list[str]) -> str | None:
    if argv[:1] != ["show"] or "--force" not in argv or "-o" not in argv:
        return None
    return os.path.normpath(argv[argv.index("-o") + 1])


def run_options(campaign: Campaign) -> None:
    folder = campaign.folder()
    write_track(folder, BASE_TEXT)
    before = digests(folder)

    @_settings(CAMPAIGN["options"])
    @given(
        options=st.lists(OPTIONS, min_size=WORKERS, max_size=WORKERS),
        envs=st.lists(st.sampled_from(["procedural", "image"]), min_size=WORKERS, max_size=WORKERS),
    )
    def check(options, envs):
        cases = [
            {
                "kind": "options",
                "args": {
                    "env_name": env,
                    "folder": str(folder) if env == "image" else None,
                    "options": option,
                },
            }
            for option, env in zip(options, envs, strict=True)
        ]
        for option, outcome in zip(options, campaign.run("options", cases), strict=True):
            assert outcome["outcome"] in ("ok", "config_error"), (option, outcome)
            if outcome["outcome"] == "config_error":
                assert all(s == "<reset options>" for s, _, _ in outcome["make"]), outcome

    check()
    assert unchanged(before, digests(folder))
