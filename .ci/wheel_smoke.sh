#!/usr/bin/env bash
# Prove the built wheel on its own: install it into a fresh virtualenv (no system packages)
# and, from an empty temporary folder, run the command, make every shipped track by name and
# run every block of the README and its docs pages.
# Usage: .ci/wheel_smoke.sh DIST_DIR   (DIST_DIR holds tinyrace-*.whl)
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
dist="$(cd "$1" && pwd)"
wheel="$(ls "$dist"/tinyrace-*.whl)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
python -m venv "$work/venv"
venv_python="$work/venv/bin/python"
"$venv_python" -m pip install -q "$wheel"
mkdir "$work/empty"
cd "$work/empty"
export PATH="$work/venv/bin:$PATH"

echo "== tinyrace --version"
tinyrace --version
echo "== tinyrace run --episodes 1"
tinyrace run --episodes 1 --quiet
ls runs/carracing-*/results.json runs/carracing-*/episode_000.mp4 >/dev/null

echo "== gym.make of every shipped track by bare name"
"$venv_python" - <<'PY'
import gymnasium as gym

import tinyrace
from tinyrace.examples import config_names, track_names

assert track_names() and config_names(), "no shipped examples in the wheel"
for name in track_names():
    env = gym.make("tinyrace/TinyRace-v0", environment=name)
    observation, _ = env.reset(seed=0)
    env.step(env.action_space.sample())
    shapes = {key: image.shape for key, image in observation.items()}
    print(f"  {name}: {shapes}")
print(f"  tinyrace {tinyrace.__version__}; configs: {', '.join(config_names())}")
PY

echo "== every shell and Python block of the README and its docs pages, in order, in one empty folder"
# Blocks marked <!-- needs: moviepy --> run after moviepy is installed; those that need a
# checkout (run by .ci/run itself), the train extra (torch; the train stage tests the same
# example), the network or RLlib are listed as skipped with their reason.
"$venv_python" -m pip install -q moviepy
"$venv_python" "$repo/.ci/readme_examples.py" --with moviepy "$repo/README.md"

echo "== the wheel holds its licence; nothing was written into the installed package"
site="$("$venv_python" -c 'import pathlib, tinyrace; print(pathlib.Path(tinyrace.__file__).parent.parent)')"
ls "$site"/tinyrace-*.dist-info/licenses/LICENSE >/dev/null
if find "$site/tinyrace" -name runs | grep -q .; then
    echo "a run folder was written into the installed package" >&2
    exit 1
fi
size_kb="$(du -sk "$site/tinyrace" "$site"/tinyrace-*.dist-info | awk '{s += $1} END {print s}')"
echo "installed wheel size: ${size_kb} KiB (wheel file: $(du -k "$wheel" | cut -f1) KiB)"
