"""A dependency-free progress line: items done / total, rate and time left.

Written to a text stream: on a terminal the line is redrawn in place (``\\r``),
on any other stream (a log file, ``io.StringIO``) each update is a new line.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["Progress", "progress_stream"]


def progress_stream(progress: bool | TextIO) -> TextIO | None:
    """Where to draw progress: ``True`` -> stderr if it is a terminal, ``False`` -> nowhere,
    a writable text stream -> always there."""
    if progress is True:
        return sys.stderr if sys.stderr is not None and sys.stderr.isatty() else None
    if progress is False or progress is None:
        return None
    if not callable(getattr(progress, "write", None)):
        raise ValueError(f"progress must be True, False or a text stream, got {progress!r}")
    return progress


def rough_duration(seconds: float, digits: int = 2) -> str:
    """A rough duration for estimates: ``"40 s"``, ``"3.2 hours"``, ``"12 years"``."""
    for unit, size in (("years", 3.156e7), ("days", 86400.0), ("hours", 3600.0), ("min", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.{digits}g} {unit}"
    return f"{seconds:.{digits}g} s"


def _duration(seconds: float) -> str:
    seconds = int(round(seconds))
    hours, rest = divmod(seconds, 3600)
    minutes, secs = divmod(rest, 60)
    if hours:
        return f"{hours}h{minutes:02d}m"
    if minutes:
        return f"{minutes}m{secs:02d}s"
    return f"{secs}s"


class Progress:
    """Progress of ``total`` items, ``done`` of them finished before this run started.

    The rate counts only items finished in this run (a resumed scan does not
    look infinitely fast).  With ``stream=None`` every method does nothing.

    Examples
    --------
    >>> import io
    >>> out = io.StringIO()
    >>> bar = Progress(4, done=1, label="f", stream=out)
    >>> out.getvalue().splitlines()[0]
    'f: 1/4 | -/s | - left'
    >>> bar.update()
    >>> out.getvalue().splitlines()[-1].startswith("f: 2/4 | ")
    True
    """

    def __init__(self, total: int, *, done: int = 0, label: str = "", stream: TextIO | None):
        self.total = int(total)
        self.done = int(done)
        self.label = label
        self.stream = stream
        self._start_done = self.done
        self._t0 = time.monotonic()
        self._tty = bool(stream is not None and getattr(stream, "isatty", lambda: False)())
        self._width = 0
        self._draw()

    def line(self) -> str:
        """The current progress text, e.g. ``f: 12/227 | 0.85/s | 4m13s left``."""
        prefix = f"{self.label}: " if self.label else ""
        text = f"{prefix}{self.done}/{self.total}"
        new = self.done - self._start_done
        elapsed = time.monotonic() - self._t0
        if new > 0 and elapsed > 0:
            rate = new / elapsed
            left = (self.total - self.done) / rate
            text += f" | {rate:.3g}/s | {_duration(left)} left"
        else:
            text += " | -/s | - left"
        return text

    def _draw(self) -> None:
        if self.stream is None:
            return
        text = self.line()
        if self._tty:
            # pad with spaces so a shorter line fully covers the previous one
            self.stream.write("\r" + text.ljust(self._width))
            self._width = len(text)
        else:
            self.stream.write(text + "\n")
        self.stream.flush()

    def update(self, n: int = 1) -> None:
        """Mark ``n`` more items as finished and redraw."""
        self.done += n
        self._draw()

    def close(self) -> None:
        """End the redrawn line (terminal only)."""
        if self.stream is not None and self._tty:
            self.stream.write("\n")
            self.stream.flush()
