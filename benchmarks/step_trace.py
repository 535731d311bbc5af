"""What one ``env.step`` passes through: the package's files, functions and calls.

Usage::

    python benchmarks/step_trace.py                       # tinyrace/CarRacing-v0
    python benchmarks/step_trace.py --id tinyrace/TinyRace-v0 --environment formula_student
    python benchmarks/step_trace.py --list                # every function, with its calls

Makes the env with ``gym.make`` (wrappers included), resets it with seed 0, takes
``--warm`` steps with a fixed action (first-call work such as the env checker's is not
counted), then records one more step with ``sys.setprofile``: each Python function of
the package (a file under ``tinyrace/``) entered during that step is a call. Prints how
many package files, distinct functions and calls the step took. Counts, not times: the
same on every machine for the same code.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path
from types import FrameType
from typing import Any

import gymnasium as gym
import numpy as np


def trace_step(env: gym.Env[Any, Any], action: Any) -> Counter[tuple[str, str]]:
    """The package functions (file relative to the package's parent, qualified name) one
    ``env.step(action)`` calls, with how often."""
    import tinyrace

    root = Path(tinyrace.__file__).resolve().parent
    prefix = str(root)
    calls: Counter[tuple[str, str]] = Counter()

    def profile(frame: FrameType, event: str, arg: object) -> None:
        if event != "call":
            return
        code = frame.f_code
        if code.co_filename.startswith(prefix):
            name = str(Path(code.co_filename).relative_to(root.parent))
            calls[name, code.co_qualname] += 1

    sys.setprofile(profile)
    try:
        env.step(action)
    finally:
        sys.setprofile(None)
    return calls


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--id", default="tinyrace/CarRacing-v0", help="the env id")
    parser.add_argument("--environment", default=None, help="TinyRace-v0's environment")
    parser.add_argument("--warm", type=int, default=20, help="steps before the traced one")
    parser.add_argument("--list", action="store_true", help="print every function")
    args = parser.parse_args(argv)
    import tinyrace  # noqa: F401  (registers the ids)

    kwargs = {} if args.environment is None else {"environment": args.environment}
    env = gym.make(args.id, **kwargs)
    env.reset(seed=0)
    space = env.action_space
    action = 3 if isinstance(space, gym.spaces.Discrete) else np.asarray(space.low)
    if isinstance(space, gym.spaces.Box) and space.shape == (3,):
        action = np.array([0.1, 0.5, 0.0], dtype=np.float32)  # steer a little, some gas
    for _ in range(args.warm):
        env.step(action)
    calls = trace_step(env, action)
    env.close()
    files = sorted({file for file, _ in calls})
    if args.list:
        for (file, function), count in sorted(calls.items()):
            print(f"{count:4d}  {file}:{function}")
    print(f"{args.id}: {len(files)} files, {len(calls)} functions, {sum(calls.values())} calls")
    for file in files:
        print(f"  {file}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
