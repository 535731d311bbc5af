"""Make the tests' helper modules (synthetic, drivers_for_tests) importable in any layout.

pytest's default import mode already puts this folder on sys.path; this also covers
``--import-mode=importlib`` and a run from the unpacked sdist against an installed wheel.
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = str(Path(__file__).resolve().parent)
if HERE not in sys.path:
    sys.path.insert(0, HERE)
