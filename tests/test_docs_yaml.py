"""Every YAML block of the README and the docs pages loads as shown, its env made and reset:
an experiment (a block with ``env:``, ``driver:`` or ``episodes:``) through
``load_experiment``, any other block as an env config (``gym.make(config=...)``). A block
that is part of a larger file says so on the line before it,
``<!-- fragment of: NAME (why) -->``: laid over the shipped track NAME (as
``gym.make(environment=NAME, **block)``) when there is one, else (a file of the reader's,
as ``my_track/track.yaml``) parsed as YAML only."""

from __future__ import annotations

import re
from pathlib import Path

import gymnasium as gym
import pytest

import tinyrace  # noqa: F401  (registers the ids)
from tinyrace.config.yaml_file import parse_yaml
from tinyrace.examples import track_names
from tinyrace.experiment.load import load_experiment

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^([ \t]*)```yaml[^\n]*\n(.*?)^\1```[ \t]*$", flags=re.S | re.M)
FRAGMENT = re.compile(r"<!--\s*fragment of:\s*(\S+)\s*(?:\(.*\))?\s*-->\s*$")
EXPERIMENT_KEYS = {"env", "driver", "drivers", "episodes"}
ID = "tinyrace/TinyRace-v0"


def yaml_blocks() -> list[tuple[str, str, str | None]]:
    """(page:line, block, the file it is a fragment of or None) of every YAML block."""
    found = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for match in FENCE.finditer(text):
            indent = len(match.group(1))
            code = "".join(line[indent:] for line in match.group(2).splitlines(keepends=True))
            before = text[: match.start()].rstrip("\n").rsplit("\n", 1)[-1]
            marker = FRAGMENT.search(before)
            line = text.count("\n", 0, match.start()) + 1
            name = f"{page.relative_to(ROOT).as_posix()}:{line}"
            found.append((name, code, marker.group(1) if marker else None))
    return found


BLOCKS = yaml_blocks()


def test_the_pages_have_yaml_blocks_of_each_kind():
    assert len(BLOCKS) >= 6
    assert any(fragment is None for _, _, fragment in BLOCKS)
    assert any(fragment in track_names() for _, _, fragment in BLOCKS)


@pytest.mark.parametrize(("where", "code", "fragment"), BLOCKS, ids=[b[0] for b in BLOCKS])
def test_every_yaml_block_loads_as_shown_or_over_the_file_it_is_a_fragment_of(
    where: str, code: str, fragment: str | None, tmp_path: Path, monkeypatch
):
    monkeypatch.chdir(tmp_path)  # a block's relative paths: a reader's empty folder
    raw = parse_yaml(code, where)  # a repeated key (alternatives in one block) fails here
    assert isinstance(raw, dict) and raw, f"{where}: not a mapping of sections"
    if fragment is None and EXPERIMENT_KEYS & raw.keys():
        (tmp_path / "experiment.yaml").write_text(code, encoding="utf-8")
        kwargs = load_experiment(tmp_path / "experiment.yaml").env_kwargs
    elif fragment is None:
        kwargs = {"config": raw}
    elif fragment in track_names():
        kwargs = {"environment": fragment, **raw}
    else:
        return  # a file of the reader's (its pictures are theirs): parsed above
    env = gym.make(ID, **kwargs)
    try:
        env.reset(seed=0)
    finally:
        env.close()
