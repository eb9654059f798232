"""Terminal output shared by the ``isp`` commands: progress display and one-line option errors."""

from __future__ import annotations

import sys


class _PlainProgress:
    """Progress as plain, periodic lines on stderr, for when it is not a terminal (rich draws no live
    bars there): a line per step, and a line per sub-task at most every ``every`` seconds."""

    def __init__(self, console, every: float = 5.0) -> None:
        import time

        self.console, self.every, self.clock = console, every, time.monotonic
        self.t0 = self.last = self.clock()
        self.tasks: dict[int, list] = {}

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        return None

    def _line(self, text: str) -> None:
        self.console.print(f"[{self.clock() - self.t0:6.1f} s] {text}", markup=False, highlight=False)
        self.last = self.clock()

    def add_task(self, description: str, total: float | None = None) -> int:
        self.tasks[len(self.tasks)] = [description, total]
        self._line(description)
        return len(self.tasks) - 1

    def update(
        self,
        task: int,
        *,
        completed: float | None = None,
        total: float | None = None,
        description: str | None = None,
    ) -> None:
        t = self.tasks[task]
        t[1] = total if total is not None else t[1]
        if description is not None and description != t[0]:
            t[0] = description
            self._line(description)
        elif completed is not None and (self.clock() - self.last >= self.every or completed == t[1]):
            self._line(f"{t[0]}: {completed:g}/{t[1]:g}" if t[1] else t[0])

    def advance(self, task: int, n: float = 1) -> None:
        return None


def _progress(console, quiet: bool):
    """Rich's live bars on a terminal; plain periodic lines otherwise (e.g. piped into a log)."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    if quiet or console.is_terminal:
        return Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            TextColumn("{task.completed}/{task.total}"),
            TimeElapsedColumn(),
            console=console,
            disable=quiet,
        )
    return _PlainProgress(console)


def _fail(message: str) -> int:
    """Bad options: ``isp: error: …`` as one line on stderr (as :func:`main` prints project errors), 2."""
    print("isp: error: " + " ".join(str(message).split()), file=sys.stderr)
    return 2
