"""Progress of long commands on stderr: the phase, one bar per task with the time remaining (tqdm).

- Bars are drawn only when stderr is a terminal, or when asked (``postcapture --progress ...``);
  they never exceed 80 columns and disappear when their task ends, leaving one line
  ``  TASK  done in 12.3 s``.
- With ``-v`` the same events are logged instead (logger ``postcapture.progress``, INFO): each
  phase, each task's start, every 10 % of it with the time remaining, and its end. That works in a
  pipe or a log file too.
- Otherwise nothing is written: a script that reads stdout gets its JSON or table alone.

The library reports through one callback signature, ``progress(task, fraction)`` (:mod:`postcapture.facade`);
:class:`ProgressDisplay` turns it into bars and lines. With :meth:`ProgressDisplay.expect` an overall line
shows how many tasks are done, running and queued, and the time remaining for all of them.
"""

from __future__ import annotations

import logging
import os
import sys
import threading
import time

__all__ = ["ProgressDisplay", "MAX_COLUMNS"]

logger = logging.getLogger("postcapture.progress")

MAX_COLUMNS = 80
"""Bars and lines are at most this wide, whatever the terminal's width."""

_TICK_S = 0.5  # bars refresh at least this often, so the elapsed time moves between updates
_REDRAW_S = 0.05  # and at most this often on updates


def _columns(stream) -> int:
    try:
        return max(20, min(os.get_terminal_size(stream.fileno()).columns, MAX_COLUMNS))
    except (OSError, AttributeError, ValueError):
        return MAX_COLUMNS


def _duration(seconds: float) -> str:
    return f"{seconds:.1f} s" if seconds < 100 else f"{seconds / 60:.1f} min"


class _Task:
    def __init__(self, name: str):
        self.name = name
        self.start = time.perf_counter()
        self.fraction = 0.0
        self.logged_decile = 0
        self.bar = None
        self.drawn = 0.0


class ProgressDisplay:
    """Phases and per-task bars for one command (a context manager).

    Parameters
    ----------
    command : str
        Shown in front of the phase lines (``"run"``, ``"simulate"``, ...).
    mode : {"auto", "on", "off"}
        ``auto`` draws bars when ``stream`` is a terminal; ``on`` always; ``off`` never.
    verbose : bool
        Log the events (INFO) instead of printing lines; bars still show on a terminal.
    stream : file, optional
        Default ``sys.stderr``.
    """

    def __init__(self, command: str, *, mode: str = "auto", verbose: bool = False, stream=None):
        self.command = command
        self.stream = stream if stream is not None else sys.stderr
        is_tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.bars = mode == "on" or (mode == "auto" and is_tty)
        self.verbose = verbose
        self.tasks: dict[str, _Task] = {}
        self._phase: tuple[str, float] | None = None
        self._phase_bar = None
        self._lock = threading.RLock()
        self._stop = threading.Event()
        self._ticker = None
        self._redirect = None
        self.expected: list[str] = []
        self._overall_bar = None
        self._overall_decile = 0
        self._overall_start = time.perf_counter()

    # context -------------------------------------------------------------------------------------
    def __enter__(self) -> ProgressDisplay:
        if self.bars:
            from tqdm.contrib.logging import logging_redirect_tqdm

            self._redirect = logging_redirect_tqdm()  # log lines print above the bars, not through them
            self._redirect.__enter__()
            self._ticker = threading.Thread(target=self._tick, name="progress-ticker", daemon=True)
            self._ticker.start()
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self._stop.set()
        if self._ticker is not None:
            self._ticker.join()
        with self._lock:
            if exc_type is None:
                self._end_phase()
            for task in self.tasks.values():
                if task.bar is not None:
                    task.bar.close()
                    task.bar = None
            for name in ("_phase_bar", "_overall_bar"):
                bar = getattr(self, name)
                if bar is not None:
                    bar.close()
                    setattr(self, name, None)
            if exc_type is not None and self.bars:
                # interrupted or failed: the line the one-line message will go on starts clean, not over a bar
                self.stream.write("\r\x1b[K")
                self.stream.flush()
        if self._redirect is not None:
            self._redirect.__exit__(exc_type, exc, tb)

    # the whole command -----------------------------------------------------------------------------
    def expect(self, names) -> None:
        """Declare the tasks to come: an overall line then shows how many are done, running and queued, and
        the time remaining for all of them."""
        with self._lock:
            self.expected = list(dict.fromkeys(names))
            if self.bars and self._overall_bar is None and len(self.expected) > 1:
                self._overall_bar = self._new_bar("  all tasks", 1000)
            self._update_overall()

    def _update_overall(self) -> None:
        if not self.expected:
            return
        fractions = [self.tasks[n].fraction if n in self.tasks else 0.0 for n in self.expected]
        done = sum(f >= 1.0 for f in fractions)
        running = sum(0.0 < f < 1.0 or (n in self.tasks and f < 1.0) for n, f in zip(self.expected, fractions))
        queued = len(self.expected) - done - running
        total = sum(fractions) / len(self.expected)
        if self._overall_bar is not None and done == len(self.expected):
            self._overall_bar.close()  # every task done: the line goes, as a task's bar does
            self._overall_bar = None
        elif self._overall_bar is not None:
            self._overall_bar.set_description_str(f"  all {len(self.expected)}: {done} done, {running} running, "
                                                  f"{queued} queued"[:38], refresh=False)
            self._overall_bar.n = int(round(1000 * total))
            self._overall_bar.refresh()
        if self.verbose and int(10 * total) > self._overall_decile:
            self._overall_decile = int(10 * total)
            elapsed = time.perf_counter() - self._overall_start
            left = elapsed * (1.0 - total) / total if total > 0 else float("nan")
            logger.info("all tasks: %d %% after %s, about %s left (%d done, %d running, %d queued)",
                        10 * self._overall_decile, _duration(elapsed), _duration(left), done, running, queued)

    def _tick(self) -> None:
        while not self._stop.wait(_TICK_S):
            with self._lock:
                for bar in [self._phase_bar, self._overall_bar] + [t.bar for t in self.tasks.values()]:
                    if bar is not None:
                        bar.refresh()

    # output --------------------------------------------------------------------------------------
    def say(self, text: str) -> None:
        """One line of news: logged with ``-v``, else printed above the bars on a terminal."""
        if self.verbose:
            logger.info(text)
        elif self.bars:
            from tqdm import tqdm

            tqdm.write(text[:MAX_COLUMNS], file=self.stream)

    def _new_bar(self, desc: str, total: float | None, position: int | None = None):
        from tqdm import tqdm

        width = _columns(self.stream)
        if total is None:  # a phase: its name and the time it has taken so far
            fmt, room = "{desc} {elapsed}", width - 9
        else:
            fmt, room = "{desc} {percentage:3.0f}%|{bar}| {elapsed}<{remaining}", width - 40
        return tqdm(total=total, desc=desc[: max(10, room)], bar_format=fmt, ncols=width, leave=False,
                    file=self.stream, mininterval=0.0, position=position, dynamic_ncols=False)

    # phases --------------------------------------------------------------------------------------
    @property
    def current_phase(self) -> str | None:
        """The phase under way, or None."""
        return None if self._phase is None else self._phase[0]

    def _end_phase(self) -> None:
        if self._phase is not None:
            name, start = self._phase
            self._phase = None
            if self._phase_bar is not None:
                self._phase_bar.close()
                self._phase_bar = None
            self.say(f"{self.command}: {name}: {_duration(time.perf_counter() - start)}")

    def phase(self, name: str) -> None:
        """Start a phase (ending the previous one, whose duration is then reported)."""
        with self._lock:
            self._end_phase()
            self._phase = (name, time.perf_counter())
            if self.verbose:
                logger.info("%s: %s ...", self.command, name)
            if self.bars:
                self._phase_bar = self._new_bar(f"{self.command}: {name}", None)

    # tasks ---------------------------------------------------------------------------------------
    def task(self, name: str, fraction: float) -> None:
        """Report a task's progress (0 to 1); its bar appears at the first report and goes at 1."""
        with self._lock:
            task = self.tasks.get(name)
            if task is None:
                task = self.tasks[name] = _Task(name)
                if self.verbose:
                    logger.info("%s: started", name)
                if self.bars:
                    task.bar = self._new_bar(f"  {name:<18}", 1000)
            elif task.fraction >= 1.0:
                return  # a late report of a finished task
            fraction = min(max(float(fraction), task.fraction), 1.0)
            if int(1000 * fraction) == int(1000 * task.fraction) and fraction < 1.0 and task.fraction > 0.0:
                return  # the truth loop reports every sample: pass on per-mille changes only
            new_decile = int(10 * fraction) > int(10 * task.fraction)
            task.fraction = fraction
            if task.bar is not None:
                task.bar.n = int(round(1000 * fraction))
                now = time.perf_counter()
                # at most every _REDRAW_S, but every tenth is drawn: a task faster than the redraw
                # interval still shows that it advanced, whatever the machine's speed
                if now - task.drawn >= _REDRAW_S or (new_decile and fraction < 1.0):
                    task.drawn = now
                    task.bar.refresh()
            if self.verbose and fraction < 1.0 and int(10 * fraction) > task.logged_decile:
                task.logged_decile = int(10 * fraction)
                elapsed = time.perf_counter() - task.start
                left = elapsed * (1.0 - fraction) / fraction
                logger.info("%s: %d %% after %s, about %s left", name, 10 * task.logged_decile,
                            _duration(elapsed), _duration(left))
            if fraction >= 1.0:
                if task.bar is not None:
                    task.bar.close()
                    task.bar = None
                self.say(f"  {name:<18} done in {_duration(time.perf_counter() - task.start)}")
            self._update_overall()

    def fraction_callback(self, name: str):
        """``progress(fraction)`` for a library call that reports one task."""
        return lambda fraction: self.task(name, fraction)
