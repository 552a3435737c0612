"""Progress of the long commands (`eval`, `robustness`, `sim2sim`) on stderr.

A command announces each batch it simulates with one line; the batch then reports its simulated
seconds. On a terminal they fill a tqdm bar; elsewhere (a log file, a CI job) a plain line says
each further tenth done, so a log shows the run moving without a line per tick.
"""

from __future__ import annotations

import sys
from typing import Callable, TextIO

Tick = Callable[[float], None]  # seconds of the batch simulated so far
Batches = Callable[[str, float], Tick]  # (what the batch is, its seconds) -> where it reports


class Report:
    """`report(title, seconds) -> tick`: prints `<command>: <title>` and returns the batch's tick.
    `bar`: a tqdm bar rather than lines (default: where `stream`, default stderr, is a terminal)."""

    def __init__(self, command: str, stream: TextIO | None = None, bar: bool | None = None):
        self.command = command
        self.stream = stream or sys.stderr
        self.bar = self.stream.isatty() if bar is None else bar

    def say(self, line: str) -> None:
        print(f"{self.command}: {line}", file=self.stream, flush=True)

    def __call__(self, title: str, seconds: float) -> Tick:
        self.say(title)
        tick = self._bar(seconds) if self.bar else self._lines(seconds)
        return lambda done: tick(min(done, seconds))  # a batch's last record may end past its seconds

    def _bar(self, seconds: float) -> Tick:
        from tqdm import tqdm

        bar = tqdm(total=round(seconds, 6), desc=self.command, unit="s", file=self.stream)

        def tick(done: float) -> None:
            bar.update(round(done, 6) - bar.n)
            if done >= seconds:
                bar.close()

        return tick

    def _lines(self, seconds: float) -> Tick:
        said = [0]  # the tenths said so far

        def tick(done: float) -> None:
            tenths = int(10 * done / seconds + 1e-9)
            if tenths > said[0]:
                said[0] = tenths
                self.say(f"{100 * done / seconds:.0f}% ({done:.3g} of {seconds:.3g} s simulated)")

        return tick
