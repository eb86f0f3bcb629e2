"""Progress of a run in simulated time, with its ETA and the wall time per simulated second.

On a terminal a tqdm bar; elsewhere (a log file, CI) a line every ``LINE_EVERY`` of the run.
Both start once the run has lasted ``DELAY`` seconds, so that short runs stay quiet.
"""

from __future__ import annotations

import math
import sys
import time

DELAY = 2.0  # s of wall time before anything shows
LINE_EVERY = 0.05  # fraction of the run between two lines when the output is not a terminal


def duration(seconds) -> str:
    """``'42s'``, ``'3m07s'``, ``'2h05m'``; ``'?'`` before it can be known."""
    if not math.isfinite(seconds):
        return "?"
    s = int(round(seconds))
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{s % 3600 // 60:02d}m"


class Progress:
    """Reports ``update(t)`` calls between ``start`` and ``total`` (simulated seconds)."""

    def __init__(self, total, start=0.0, stream=None, clock=time.monotonic):
        self.total, self.start = total, start
        self.stream = sys.stderr if stream is None else stream
        self.clock = clock
        self.t0 = clock()
        self.next_line = start + LINE_EVERY * (total - start)
        self.bar = None
        if self.stream.isatty():
            from tqdm import tqdm

            self.bar = tqdm(total=total, initial=start, unit="s(sim)", delay=DELAY,
                            file=self.stream, bar_format="{l_bar}{bar}| {n:.4g}/{total:.4g} s "
                            "[{elapsed}, ETA {remaining}{postfix}]")

    def rates(self, t):
        """(elapsed, wall seconds per simulated second, ETA) at simulated time ``t``."""
        elapsed = self.clock() - self.t0
        per = elapsed / (t - self.start) if t > self.start else float("nan")
        return elapsed, per, per * (self.total - t)

    def update(self, t):
        _, per, _ = self.rates(t)
        if self.bar is not None:
            self.bar.set_postfix_str(f"{duration(per)} per simulated s", refresh=False)
            self.bar.update(min(t, self.total) - self.bar.n)
        elif t >= self.next_line:
            self.line(t)
            steps = int((t - self.start) / (LINE_EVERY * (self.total - self.start))) + 1
            self.next_line = self.start + steps * LINE_EVERY * (self.total - self.start)

    def line(self, t):
        elapsed, per, eta = self.rates(t)
        if elapsed < DELAY:
            return
        print(f"fsi-sph: t = {t:.4g} / {self.total:.4g} s ({100 * t / self.total:.0f} %), "
              f"{duration(elapsed)} elapsed, ETA {duration(eta)}, {duration(per)} per "
              f"simulated s", file=self.stream, flush=True)

    def close(self):
        if self.bar is not None:
            self.bar.close()
