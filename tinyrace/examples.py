"""The example tracks and experiment configs shipped with the package, found by bare name.

A value that names an existing file or folder is always that path (a bare name ``NAME``
first as ``NAME.yaml`` in the working folder, as ``tinyrace examples copy`` leaves it);
otherwise a bare name (``formula_student``) stands for the shipped track folder or
experiment file of that name, from any working folder. An unknown name raises a
ConfigError that lists the known names, the closest first.

Their one copy is the repository's top-level ``example_tracks/`` and ``configs/``
folders. pyproject.toml's ``package-dir`` maps them to the packages
``tinyrace.example_tracks`` and ``tinyrace.configs``, so a wheel holds them inside the
installed package; a source checkout or an editable install reads them beside it.
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass
from pathlib import Path

from tinyrace.errors import ConfigError, Problem, did_you_mean, one_of

PACKAGE_DIR = Path(__file__).resolve().parent


def shipped_folder(name: str) -> Path:
    """The shipped folder ``name``: inside the installed package (a wheel), else the
    repository's top-level folder beside the package (a checkout or an editable install)."""
    installed = PACKAGE_DIR / name
    return installed if installed.is_dir() else PACKAGE_DIR.parent / name


TRACKS_DIR = shipped_folder("example_tracks")  # one tinycarlo track folder per example
CONFIGS_DIR = shipped_folder("configs")  # one experiment file per example
DEFAULT_EXPERIMENT = CONFIGS_DIR / "carracing.yaml"
TRACK_FILE = "track.yaml"
CONFIG_SUFFIX = ".yaml"


@dataclass(frozen=True)
class Example:
    """One shipped example: a track folder or an experiment file."""

    kind: str  # "track" or "config"
    name: str  # the bare name it is found by
    path: Path  # the folder (track) or the YAML file (config)

    @property
    def summary(self) -> str:
        """The first sentence of its YAML file's opening comment (what the example shows)."""
        text = (self.path / TRACK_FILE if self.kind == "track" else self.path).read_text("utf-8")
        comment = []
        for line in text.splitlines():
            if not line.startswith("#"):
                break
            comment.append(line.lstrip("#").strip())
        sentence = " ".join(comment).split(". ")[0]
        return sentence if sentence.endswith(".") or not sentence else sentence + "."


def track_names() -> list[str]:
    """The bare names of the shipped track folders, sorted."""
    return sorted(p.parent.name for p in TRACKS_DIR.glob(f"*/{TRACK_FILE}"))


def config_names() -> list[str]:
    """The bare names of the shipped experiment files, sorted."""
    return sorted(p.stem for p in CONFIGS_DIR.glob(f"*{CONFIG_SUFFIX}"))


def examples() -> list[Example]:
    """Every shipped example: the tracks, then the configs."""
    tracks = [Example("track", n, TRACKS_DIR / n) for n in track_names()]
    configs = [Example("config", n, CONFIGS_DIR / f"{n}{CONFIG_SUFFIX}") for n in config_names()]
    return tracks + configs


def is_bare_name(value: object) -> bool:
    """A plain name without folders or a suffix, as the shipped examples are named."""
    return isinstance(value, str) and bool(value) and Path(value).name == value and "." not in value


def shipped_track(name: object, source: str = "<kwargs>", key: str = "environment") -> Path:
    """The shipped track folder called ``name``; ConfigError listing the known tracks if none."""
    if is_bare_name(name) and name in track_names():
        return TRACKS_DIR / str(name)
    names = track_names()
    allowed = (
        f"{did_you_mean(name, names)}expected a track folder holding {TRACK_FILE} "
        f"or a shipped track: {', '.join(names)}"
    )
    raise ConfigError(Problem(source, key, str(name), allowed))


def find_track(value: str | Path) -> Path:
    """The path as given if it exists or is no bare name, else the shipped track of that name."""
    if _exists(Path(value)) or not is_bare_name(value):
        return Path(value)
    return shipped_track(value)


def find_experiment(value: str | Path, key: str = "experiment") -> Path:
    """An experiment file as given if it exists, else the shipped config of that name."""
    path = local_path(value)
    if _exists(path) or not is_bare_name(str(value)):
        return path  # the loader reports a missing file in its own words
    if str(value) in config_names():
        return CONFIGS_DIR / f"{value}{CONFIG_SUFFIX}"
    allowed = one_of(value, config_names(), "a YAML file or a shipped config")
    raise ConfigError(Problem("<command line>", key, str(value), allowed))


def find_example(value: str | Path, key: str = "path") -> Path:
    """For run/validate/show/play: a path if it exists (``NAME.yaml`` here first), else a
    shipped config, else a shipped track."""
    path = local_path(value)
    if _exists(path) or not is_bare_name(str(value)):
        return path
    if str(value) in config_names():
        return CONFIGS_DIR / f"{value}{CONFIG_SUFFIX}"
    if str(value) in track_names():
        return TRACKS_DIR / str(value)
    hint = did_you_mean(value, [*config_names(), *track_names()])
    allowed = (
        f"{hint}expected a path, a shipped config ({', '.join(config_names())}) "
        f"or a shipped track ({', '.join(track_names())})"
    )
    raise ConfigError(Problem("<command line>", key, str(value), allowed))


def local_path(value: str | Path) -> Path:
    """``value`` as a path; a bare ``NAME`` is ``NAME.yaml`` when that file is here (a copied
    experiment, which runs its copied track folder ``NAME`` beside it)."""
    if is_bare_name(str(value)):
        named = Path(f"{value}{CONFIG_SUFFIX}")
        if _is_file(named):
            return named
    return Path(value)


def copy_example(name: str, folder: Path) -> list[Path]:
    """Copy every shipped example called ``name`` (track folder and/or config) into ``folder``.

    Refuses, copying nothing, when a target already exists (a symbolic link too, even one
    that points nowhere: nothing is written through a link), when ``folder`` lies inside the
    installed package or its shipped folders, or when a shipped file is a link that does
    not resolve inside its shipped folder. A link inside is copied as the file it names,
    under the link's own name. A copied config keeps its bare ``environment:`` name, which
    now finds the copied track folder next to it.
    """
    chosen = [e for e in examples() if e.name == name]
    if not chosen:
        allowed = one_of(name, {e.name for e in examples()})
        raise ConfigError(Problem("<command line>", "name", name, allowed))
    if _exists(folder) and not folder.is_dir():
        allowed = "a folder (or a path that does not exist yet), not a file"
        raise ConfigError(Problem("<command line>", "DIR", str(folder), allowed))
    shipped = shipped_holding(folder)
    if shipped is not None:
        allowed = (
            f"a folder outside the installed package ({shipped} holds tinyrace's own "
            "files): copy it elsewhere"
        )
        raise ConfigError(Problem("<command line>", "DIR", str(folder), allowed))
    targets = [(e, folder / e.path.name) for e in chosen]
    for _, target in targets:
        if _lexists(target):
            kind = " (a symbolic link)" if target.is_symlink() else ""
            allowed = (
                f"a folder where {target.name} does not exist yet ({target} exists{kind}; "
                "nothing is overwritten)"
            )
            raise ConfigError(Problem("<command line>", "DIR", str(folder), allowed))
    for example, _ in targets:
        _check_links(example)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        for example, target in targets:
            if example.kind == "track":
                shutil.copytree(example.path, target, copy_function=_copy_file)
            else:
                _copy_file(example.path, target)
    except (OSError, ValueError) as exc:  # no permission, a name too long, a NUL byte
        allowed = f"a folder that can be written ({type(exc).__name__}: {exc})"
        raise ConfigError(Problem("<command line>", "DIR", str(folder), allowed)) from None
    return [target for _, target in targets]


def shipped_holding(path: Path) -> Path | None:
    """The installed package's folder, or the shipped tracks' or configs' folder, that
    ``path`` lies in (resolved: through links), or None: no user file belongs there."""
    try:
        resolved = path.resolve()
        roots = (PACKAGE_DIR, TRACKS_DIR.resolve(), CONFIGS_DIR.resolve())
    except (OSError, ValueError, RuntimeError):  # a name the OS refuses, a link loop
        return None
    return next((root for root in roots if resolved.is_relative_to(root)), None)


def _check_links(example: Example) -> None:
    """Every link among the example's files resolves to a file or folder inside the
    shipped folder it lies in; else a ConfigError (the package was altered)."""
    root = example.path.parent.resolve()
    paths = [example.path]
    if example.kind == "track" and example.path.is_dir() and not example.path.is_symlink():
        paths += sorted(example.path.rglob("*"))
    for path in paths:
        if not path.is_symlink():
            continue
        try:
            resolved = path.resolve(strict=True)
        except (OSError, RuntimeError):
            resolved = None
        if resolved is None or not resolved.is_relative_to(root):
            allowed = (
                f"a shipped example whose files lie in the package: {path} is a symbolic "
                "link that does not resolve inside it (reinstall tinyrace)"
            )
            raise ConfigError(Problem("<command line>", "name", example.name, allowed))


def _copy_file(source: str | Path, target: str | Path) -> None:
    """``source``'s content (through a link) as a new file ``target``, never through a link
    at ``target`` nor over a file there (O_EXCL); mode 0644 less the umask."""
    data = Path(source).read_bytes()
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
    fd = os.open(target, flags, 0o644)
    with os.fdopen(fd, "wb") as file:
        file.write(data)


def _lexists(path: Path) -> bool:
    """Whether anything is at ``path``, a link that points nowhere too."""
    try:
        return os.path.lexists(path)
    except (OSError, ValueError):  # a name the OS refuses (too long, NUL byte)
        return False


def _is_file(path: Path) -> bool:
    try:
        return path.is_file()
    except (OSError, ValueError):  # a name the OS refuses (too long, NUL byte)
        return False


def _exists(path: Path) -> bool:
    try:
        return path.exists()
    except (OSError, ValueError):  # a name the OS refuses (too long, NUL byte)
        return False
