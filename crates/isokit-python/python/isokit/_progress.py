"""Progress reporting for long calls: tqdm bars, or the caller's callback.

Every long call (`Shape.sample`, `Shape.mesh`, `Shape.render`, `signed_distance`, the
level-set operations, evaluations of many points) takes ``progress=``:

- ``None`` (default): a tqdm bar when tqdm is installed and the output is a terminal or a
  notebook, shown only for calls that take longer than half a second;
- ``True``: a tqdm bar whenever tqdm is installed;
- ``False``: nothing;
- a callable ``progress(stage, done, total)``: called from the calling thread about every
  50 ms with the latest report (``total`` may be 0 when unknown); returning ``False``
  cancels the call, which then raises ``isokit.Cancelled``.

Ctrl-C cancels any long call cleanly and raises ``KeyboardInterrupt``.
"""

from __future__ import annotations

import sys


def _interactive() -> bool:
    try:
        if sys.stderr is not None and sys.stderr.isatty():
            return True
    except (AttributeError, ValueError):
        pass
    return "ipykernel" in sys.modules


class _Callback:
    def __init__(self, f):
        self.f = f

    def update(self, stage, done, total):
        return self.f(stage, done, total)

    def close(self):
        pass


class _Tqdm:
    def __init__(self, tqdm, desc, delay):
        self.tqdm, self.desc, self.delay = tqdm, desc, delay
        self.bar, self.stage = None, None

    def update(self, stage, done, total):
        if stage != self.stage or self.bar is None:
            self.close()
            self.stage = stage
            self.bar = self.tqdm(
                total=total or None, desc=f"{self.desc}: {stage}", delay=self.delay, leave=False
            )
        self.bar.n = done
        self.bar.refresh()

    def close(self):
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def reporter(progress, desc):
    """The object the native module reports to (``update``, ``close``), or None."""
    if progress is False:
        return None
    if progress is None or progress is True:
        if progress is None and not _interactive():
            return None
        try:
            from tqdm.auto import tqdm
        except ImportError:
            return None
        return _Tqdm(tqdm, desc, 0.5 if progress is None else 0.0)
    if callable(progress):
        return _Callback(progress)
    raise TypeError("progress must be None, True, False or a callable(stage, done, total)")
