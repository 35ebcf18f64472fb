"""A minimal progress bar on standard error, for long inputs."""

from collections.abc import Sequence
import sys
import time
from typing import Optional, TextIO

#: Samples from which a recording's fit shows its stages (a few seconds of work and more).
LONG_RECORDING = 20000


class Progress:
    """
    Report progress of ``total`` units on a terminal.

    Draws at most ten times a second. ``show``: None (the default) draws
    only when the stream is a terminal and the input is long (at least
    ``min_total`` units); True draws whatever the stream (a notebook's
    standard error); False never draws.
    """

    def __init__(self, total: int, label: str, stream: Optional[TextIO] = None,
                 min_total: int = 20000, show: Optional[bool] = None) -> None:
        self.stream = stream or sys.stderr
        self.total = max(int(total), 1)
        self.label = label
        self.enabled = show if show is not None else \
            total >= min_total and getattr(self.stream, 'isatty', lambda: False)()
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


def stage_progress(samples: Sequence[int], names: Sequence[str], stages: int, what: str,
                   show: Optional[bool] = None) -> Progress:
    """
    Return a bar over a fit's ``stages`` stages, shown for long recordings.

    ``samples`` and ``names``: the recordings'. ``show`` as :class:`Progress`'s.
    """
    name = names[0] if len(names) == 1 else f'{len(names)} recordings'
    return Progress(stages, f'{what} {name}',
                    min_total=0 if sum(samples) >= LONG_RECORDING else stages + 1, show=show)
