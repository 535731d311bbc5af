"""Run every Python example of the README, each in its own interpreter and empty folder.

Usage: python .ci/readme_examples.py [README]   (the interpreter running this is the one
used, so run it with the virtualenv that has the wheel installed). Examples that import
an optional training library (stable_baselines3, ray) or whose first line says
``# needs: <extra>`` are listed but not run: the train extra's own test covers the first,
RLlib is documented, not installed, and the README names what the others need.
"""

from __future__ import annotations

import re
import subprocess
import sys
import tempfile
from pathlib import Path

OPTIONAL = ("stable_baselines3", "ray")  # modules of examples that need the train extras
TIMEOUT = 300  # [s] per example


def examples(readme: Path) -> list[tuple[int, str]]:
    """(line, code) of each ```python block."""
    text = readme.read_text(encoding="utf-8")
    found = []
    for match in re.finditer(r"^```python\n(.*?)^```", text, flags=re.S | re.M):
        found.append((text.count("\n", 0, match.start()) + 1, match.group(1)))
    return found


def needs_optional(code: str) -> str | None:
    marker = re.match(r"#\s*needs:\s*(.+)", code)
    if marker:
        return marker.group(1).strip()
    for module in OPTIONAL:
        if re.search(rf"^\s*(from|import) {module}\b", code, flags=re.M):
            return module
    return None


def main(argv: list[str]) -> int:
    readme = Path(argv[1] if len(argv) > 1 else Path(__file__).parents[1] / "README.md")
    failed = 0
    for line, code in examples(readme):
        optional = needs_optional(code)
        if optional is not None:
            print(f"README line {line}: needs {optional} (an optional extra): not run here")
            continue
        with tempfile.TemporaryDirectory() as empty:
            done = subprocess.run(
                [sys.executable, "-c", code],
                cwd=empty,
                capture_output=True,
                text=True,
                timeout=TIMEOUT,
            )
        status = "ok" if done.returncode == 0 else f"FAILED (exit {done.returncode})"
        print(f"README line {line}: {status}")
        if done.returncode != 0:
            failed += 1
            print(done.stderr[-3000:], file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
