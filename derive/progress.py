"""A progress bar on stderr for long work (simulations, sweeps), shown only when the
work takes longer than ``delay`` seconds.  On a terminal it redraws one line; otherwise
(a log file, CI) it writes a plain line at most every 10 % and no carriage returns.
Also :func:`count`, the counts in the lines and titles that report work."""
from __future__ import annotations

import sys
import time


def count(n: int, noun: str, plural: str | None = None) -> str:
    """"1 impact", "2 impacts"; ``plural`` for a noun that does not take an s ("pushes")."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"


class Bar:
    def __init__(self, label: str, enabled: bool = True, delay: float = 1.0, width: int = 30):
        self.label, self.enabled, self.delay, self.width = label, enabled, delay, width
        self.start = time.perf_counter()
        self.shown = False
        self.tty = sys.stderr.isatty()
        self.last_decile = -1

    def update(self, fraction: float, note: str = "") -> None:
        if not self.enabled:
            return
        elapsed = time.perf_counter() - self.start
        if elapsed < self.delay:
            return
        frac = min(max(fraction, 0.0), 1.0)
        eta = f"  {elapsed * (1 - frac) / frac:5.0f} s left" if 0 < frac < 1 else ""
        if not self.tty:
            decile = int(10 * frac)
            if decile > self.last_decile:
                self.last_decile = decile
                print(f"  {self.label}: {100 * frac:3.0f}%  {note}{eta}", file=sys.stderr,
                      flush=True)
            return
        bar = "#" * int(self.width * frac)
        print(f"\r  {self.label} [{bar:<{self.width}}] {100 * frac:5.1f}%  {note}{eta}",
              end="", file=sys.stderr, flush=True)
        self.shown = True

    def stage(self, text: str) -> None:
        """A line on stderr when a stage of the work without a fraction begins ("drawing
        overview.png"), once the work has taken ``delay`` (a quick run stays silent)."""
        if not self.enabled or time.perf_counter() - self.start < self.delay:
            return
        self.close()
        self.shown = False
        print(f"  {text} ...", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.shown:
            print(file=sys.stderr, flush=True)
