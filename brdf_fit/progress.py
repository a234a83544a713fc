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
            # tqdm's own remaining time extrapolates from the first step too: left out ("eta" below)
            self.bar = tqdm(total=total, desc=label, file=self.stream, ncols=min(width, 120),
                            bar_format="{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}{postfix}]")
        self.first = None        # when the first step ended: it carries the compiling

    def message(self, text: str) -> None:
        if self.bar is not None:
            self.bar.write(text, file=self.stream)
        else:
            self.stream.write(f"{text}\n")
            self.stream.flush()

    def eta(self) -> str:
        """The time left, from the steps after the first (the first compiles the programs the
        others reuse: counting it swung a fresh run's estimate by 20x); "" until there are two."""
        if self.first is None or self.done < 2 or self.done >= self.total:
            return ""
        per_step = (time.perf_counter() - self.first) / (self.done - 1)
        return f"ETA {per_step * (self.total - self.done):.0f}s"

    def step(self, note: str = "") -> None:
        self.done += 1
        if self.first is None:
            self.first = time.perf_counter()
        eta = self.eta()
        if self.bar is not None:
            self.bar.set_postfix_str(", ".join(x for x in (eta, note[:40]) if x), refresh=False)
            self.bar.update(1)
            if self.done == self.total:
                self.bar.close()
            return
        elapsed = time.perf_counter() - self.start
        self.stream.write(f"[{self.done}/{self.total} {self.label}  {elapsed:5.1f}s elapsed"
                          f"{', ' + eta if eta else ''}] {note}\n")
        self.stream.flush()
