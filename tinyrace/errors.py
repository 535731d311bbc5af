"""The one error type users see for bad configuration."""

from __future__ import annotations

import difflib
import reprlib
import stat
from collections.abc import Iterable
from dataclasses import dataclass


@dataclass(frozen=True)
class Problem:
    """One thing wrong with a configuration, located precisely."""

    source: str  # the file (or "<dict>" / "<kwargs>") the value came from
    path: str  # dotted key path, e.g. "cameras[0].roi"
    value: object  # the offending value, as read
    allowed: str  # what would have been accepted

    def __str__(self) -> str:
        where = f"{self.source}: {self.path}" if self.path else self.source
        return f"{where}: got {shown(self.value)}; {self.allowed}"


@dataclass(frozen=True)
class Omitted(Problem):
    """The problems of a list cut short: how many more were found and not listed."""

    count: int = 0  # problems found beyond those listed

    def __str__(self) -> str:
        where = f"{self.source}: {self.path}" if self.path else self.source
        return f"{where}: ... and {self.count:,} more problem(s) like these, not listed"


def capped(problems: list[Problem], limit: int = 20, found: int | None = None) -> list[Problem]:
    """The first ``limit`` of ``problems`` and, when more were ``found`` (by default as many
    as given), an ``Omitted`` problem that says how many more there are."""
    total = len(problems) if found is None else found
    shown_ = problems[:limit]
    if total <= len(shown_):
        return shown_
    source = shown_[-1].source if shown_ else ""
    more = total - len(shown_)
    return [*shown_, Omitted(source, "", more, f"{more:,} more not listed", more)]


def problem_count(problems: Iterable[Problem]) -> int:
    """How many problems were found: each listed one, and the count each ``Omitted`` stands for."""
    return sum(p.count if isinstance(p, Omitted) else 1 for p in problems)


_SHORT = reprlib.Repr()  # containers are cut before they are turned into text
_SHORT.maxstring, _SHORT.maxother, _SHORT.maxlong = 80, 80, 40
_SHORT.maxlist = _SHORT.maxtuple = _SHORT.maxdict = _SHORT.maxset = 8
_SHORT.maxlevel = 4


def shown(value: object) -> str:
    """A value as a short text: a huge list, string or number is never turned whole into text."""
    if isinstance(value, int) and value.bit_length() > 256:  # repr of huge ints is slow or fails
        return f"<an integer of {value.bit_length()} bits>"
    try:
        text = _SHORT.repr(value)
    except Exception:  # a user object whose repr fails
        text = f"<{type(value).__name__}>"
    return text if len(text) <= 80 else text[:38] + "..." + text[-39:]  # both ends of a path


def cut_middle(text: str, limit: int = 80) -> str:
    """``text``, its middle cut out when longer than ``limit`` characters (a long path keeps
    both ends)."""
    half = (limit - 3) // 2
    return text if len(text) <= limit else text[:half] + "..." + text[-half:]


def file_kind(mode: int) -> str:
    """What a file of ``os.stat``'s ``mode`` is, for a message: "a folder", "a FIFO", ..."""
    kinds = (
        (stat.S_ISREG, "a file"),
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISLNK, "a symbolic link"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    )
    return next((name for test, name in kinds if test(mode)), "a special file")


class UsageError(Exception):
    """A bad command line: one line on stderr, exit 2."""


def did_you_mean(value: object, names: Iterable[str], cutoff: float = 0.6) -> str:
    """``"did you mean 'x'? "`` when ``value`` is a close misspelling of one of ``names``, else
    ``""``: put before the list of valid names in a message."""
    if not isinstance(value, str):
        return ""
    close = difflib.get_close_matches(value, list(names), n=1, cutoff=cutoff)
    return f"did you mean {close[0]!r}? " if close and close[0] != value else ""


def one_of(value: object, names: Iterable[str], what: str = "one of") -> str:
    """What a name lookup allows: the closest name first (if any), then every valid name."""
    listed = sorted(set(names))
    return f"{did_you_mean(value, listed)}expected {what}: {', '.join(listed)}"


def one_line(exc: BaseException) -> str:
    """An exception as one line, to quote inside another message: a ConfigError's problems
    joined by '; ' (not its multi-line text), anything else ``Type: text`` on one line."""
    if isinstance(exc, ConfigError):
        return "; ".join(str(p) for p in exc.problems)
    return " ".join(f"{type(exc).__name__}: {exc}".split())


class ConfigError(ValueError):
    """Raised for any invalid track, environment or experiment configuration.

    Every problem names the file, the key path, the value and what is allowed;
    all problems found in one pass are reported together in ``problems``.
    """

    def __init__(self, problems: list[Problem] | Problem):
        self.problems = [problems] if isinstance(problems, Problem) else list(problems)
        lines = [str(p) for p in self.problems]
        count = problem_count(self.problems)
        head = "invalid configuration" if count == 1 else f"{count:,} configuration problems"
        super().__init__(head + ":\n  " + "\n  ".join(lines))

    def __reduce__(self) -> tuple[type[ConfigError], tuple[list[Problem]]]:
        """Pickle by the problems, so the error crosses process boundaries (vector envs)."""
        return ConfigError, (self.problems,)
