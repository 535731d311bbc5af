"""``python -m tinyrace``: the same as the ``tinyrace`` command."""

from tinyrace.cli import main

raise SystemExit(main())
