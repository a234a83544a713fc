"""Progress on stderr for the commands' long work (fits, batches, reports)."""

import sys
import time
from typing import TextIO


class Progress:
    """Progress on stderr: a tqdm bar on a terminal, one plain line per step otherwise
    (a log file gets readable lines, not carriage returns).

    ``message`` prints a line above the bar (never glued onto it).
    """

    def __init__(self, total: int, label: str, stream: TextIO | None = None) -> None:
        self.total, self.label, self.stream = total, label, stream or sys.stderr
        self.done, self.start = 0, time.perf_counter()
        self.bar = None
        if hasattr(self.stream, "isatty") and self.stream.isatty():
            import shutil
            from tqdm import tqdm
            width = shutil.get_terminal_size((100, 24)).columns or 100
            self.bar = tqdm(total=total, desc=label, file=self.stream, ncols=min(width, 120))

    def message(self, text: str) -> None:
        if self.bar is not None:
            self.bar.write(text, file=self.stream)
        else:
            self.stream.write(f"{text}\n")
            self.stream.flush()

    def step(self, note: str = "") -> None:
        self.done += 1
        if self.bar is not None:
            self.bar.set_postfix_str(note[:40], refresh=False)
            self.bar.update(1)
            if self.done == self.total:
                self.bar.close()
            return
        elapsed = time.perf_counter() - self.start
        eta = elapsed / self.done * (self.total - self.done)
        self.stream.write(f"[{self.done}/{self.total} {self.label}  {elapsed:5.1f}s elapsed, "
                          f"ETA {eta:5.1f}s] {note}\n")
        self.stream.flush()
