"""The toolkit's own error and warning types for measured-data files."""

import os
import warnings


class MeasuredDataError(Exception):
    """A measured-data file could not be read.

    The message always names the file and says what is wrong with it, so a
    command line can print it as is (no traceback needed).
    """

    def __init__(self, path: str | os.PathLike[str] | None, problem: str) -> None:
        self.path = os.fspath(path) if path is not None else "<memory>"
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


class MeasuredDataWarning(UserWarning):
    """A measured-data file was read but its content looks implausible (all
    zeros, values far above any measured BRDF, directions that were not unit
    length). The message names the file and says what looks wrong, in one
    short sentence."""


def warn_data(path: str | os.PathLike[str] | None, problem: str, stacklevel: int = 2) -> None:
    """Emit a :class:`MeasuredDataWarning` ``"{path}: {problem}"``.

    ``stacklevel`` counts from the caller of this function (2 = the caller's caller).
    """
    path = os.fspath(path) if path is not None else "<memory>"
    warnings.warn(MeasuredDataWarning(f"{path}: {problem}"), stacklevel=stacklevel + 1)


def require_file(path: str | os.PathLike[str], kind: str = "measured-data file") -> str:
    """``path`` as a str if it names an existing file; else MeasuredDataError
    ("no such file" / "is a directory, not a KIND")."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise MeasuredDataError(path, "no such file")
    if os.path.isdir(path):
        raise MeasuredDataError(path, f"is a directory, not a {kind}")
    return path

