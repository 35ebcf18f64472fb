"""A minimal progress bar on standard error, for long inputs."""

import sys
import time
from typing import Optional, TextIO


class Progress:
    """
    Report progress of ``total`` units on a terminal.

    Draws only when the stream is a terminal and the input is long (at least
    ``min_total`` units), at most ten times a second.
    """

    def __init__(self, total: int, label: str, stream: Optional[TextIO] = None,
                 min_total: int = 20000) -> None:
        self.stream = stream or sys.stderr
        self.total = max(int(total), 1)
        self.label = label
        self.enabled = total >= min_total and getattr(self.stream, 'isatty',
                                                      lambda: False)()
        self.done = 0
        self._last = 0.0

    def update(self, n: int = 1) -> None:
        """Advance by ``n`` units."""
        self.done += n
        now = time.monotonic()
        if self.enabled and (now - self._last > 0.1 or self.done >= self.total):
            self._last = now
            frac = min(self.done / self.total, 1.0)
            bar = '#' * int(30 * frac)
            self.stream.write(f'\r{self.label} [{bar:<30}] {100 * frac:5.1f}%')
            self.stream.flush()

    def close(self) -> None:
        """Finish the line."""
        if self.enabled:
            self.stream.write('\n')
            self.stream.flush()
