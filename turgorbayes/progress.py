"""Progress of a loop: a tqdm bar on a terminal, whole lines in a log file, nothing for no work.

A bar redraws itself with carriage returns, which turn a log file into one long line; so where
the stream is not a terminal each report is one line (:class:`ProgressLines`).
"""

import sys
import time

__all__ = ["ProgressLines", "note", "progress"]


def progress(iterable=None, *, total=None, desc="", unit="it", enabled=True, file=None,
             **bar_options):
    """A progress bar over ``iterable`` (or ``total`` steps updated by hand).

    Parameters
    ----------
    iterable : iterable, optional
        Wrapped; its length is the total unless ``total`` is given.
    total : float, optional
        Number of steps (items, or per cent).
    desc, unit : str
        What runs and what a step is ("curves", "file").
    enabled : bool
        False: no output at all.
    file : file-like, optional
        Default ``sys.stderr`` at the time of the call.
    **bar_options
        Passed to :class:`tqdm.tqdm` on a terminal (``leave``, ``bar_format``); ignored otherwise.

    Returns
    -------
    tqdm.tqdm or ProgressLines
        A tqdm bar when ``file`` is a terminal; otherwise :class:`ProgressLines`. Both iterate,
        ``update``, ``set_postfix``/``set_postfix_str``, ``write``, ``close`` and are context
        managers; with ``enabled`` False or nothing to do (a total of 0) they print nothing.
    """
    from tqdm import tqdm

    file = sys.stderr if file is None else file
    if total is None and iterable is not None and hasattr(iterable, "__len__"):
        total = len(iterable)
    if not enabled or total == 0:
        return tqdm(iterable, total=total, disable=True)
    if _is_terminal(file):
        return tqdm(iterable, total=total, desc=desc, unit=unit, file=file, **bar_options)
    return ProgressLines(iterable, total=total, desc=desc, unit=unit, file=file)


def note(message, enabled=True, file=None):
    """Say what is about to run, as one line on ``file`` (default ``sys.stderr``), at once."""
    if enabled:
        print(message, file=sys.stderr if file is None else file, flush=True)


def _is_terminal(file):
    try:
        return bool(file.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


class ProgressLines:
    """Progress as whole lines, for a stream that is not a terminal.

    A line at every step when there are at most ``steps`` of them, else at each further tenth
    of the total (``1/steps``), and at least every ``interval`` seconds; always at the end.
    Each line reads ``desc: n/total unit (p %), t s[, postfix]`` (``desc: p %, ...`` for a
    total in per cent).

    Parameters
    ----------
    iterable : iterable, optional
    total : float, optional
        Unknown: a line per ``interval`` seconds and at the end.
    desc, unit : str
    file : file-like
    steps : int
        Lines per run at most, besides the timed ones.
    interval : float [s]
    clock : callable
        Seconds (:func:`time.monotonic`; replaced in tests).
    """

    def __init__(self, iterable=None, *, total=None, desc="", unit="it", file=None, steps=10,
                 interval=60.0, clock=time.monotonic):
        self.iterable, self.total, self.desc, self.unit = iterable, total, desc, unit
        self.file = sys.stderr if file is None else file
        self.n, self.postfix = 0, ""
        self._steps, self._interval, self._clock = steps, interval, clock
        self._start = self._last_time = clock()
        self._last_n, self._closed = 0, False

    def __iter__(self):
        for item in self.iterable:
            yield item
            self.update(1)
        self.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def update(self, n=1):
        """Advance by ``n`` steps; print a line if one is due."""
        self.n += n
        if self._due():
            self._line()

    def set_postfix_str(self, s="", refresh=True):
        """Text appended to the next lines (as tqdm's postfix)."""
        self.postfix = str(s)

    def set_postfix(self, refresh=True, **kwargs):
        """``key=value`` text appended to the next lines."""
        self.postfix = ", ".join(f"{k}={v}" for k, v in kwargs.items())

    def write(self, s, file=None):
        """Print ``s`` as its own line."""
        print(s, file=file or self.file, flush=True)

    def close(self):
        """Print the last line, unless the last step already did."""
        if not self._closed and self.n != self._last_n:
            self._line()
        self._closed = True

    def _due(self):
        if self._clock() - self._last_time >= self._interval:
            return True
        if not self.total:
            return False
        if self.total <= self._steps:
            return True
        return (int(self._steps * self.n / self.total)
                > int(self._steps * self._last_n / self.total)) or self.n >= self.total

    def _line(self):
        now = self._clock()
        if self.unit == "%":  # a bar in per cent (sampling to convergence)
            done = f"{self.n:.0f} %"
        elif self.total is None:
            done = f"{self.n:g} {self.unit}"
        else:
            done = f"{self.n:g}/{self.total:g} {self.unit} ({100 * self.n / self.total:.0f} %)"
        tail = f", {self.postfix}" if self.postfix else ""
        print(f"{self.desc}: {done}, {now - self._start:.0f} s{tail}",
              file=self.file, flush=True)
        self._last_n, self._last_time = self.n, now
