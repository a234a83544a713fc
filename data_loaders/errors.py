"""The toolkit's own error type for bad measured-data files."""

import os


class MeasuredDataError(Exception):
    """A measured-data file could not be read.

    The message always names the file and says what is wrong with it, so a
    command line can print it as is (no traceback needed).
    """

    def __init__(self, path, problem):
        self.path = os.fspath(path) if path is not None else "<memory>"
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")
