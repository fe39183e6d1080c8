"""Counting unhandled exceptions: whatever escapes a thread, the event loop, or lands in
a log with a traceback (or at ERROR), from any logger, uvicorn's included."""

from __future__ import annotations

import logging
import sys
import threading
from types import TracebackType
from typing import Any

# The station's side: the root (backend, viser), uvicorn, the WebSocket servers (viser's),
# asyncio. Not "websockets.client": the fuzzers' own clients are not under test.
_LOGGERS = ("", "uvicorn", "uvicorn.error", "websockets.server", "asyncio")


class Watch(logging.Handler):
    """Use as a context manager; ``count`` and ``samples`` say what escaped."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.count = 0
        self.samples: list[str] = []
        self._old_hook: Any = None
        self._old_unraisable: Any = None

    def _note(self, text: str) -> None:
        self.count += 1
        if len(self.samples) < 5:
            self.samples.append(text[:400])

    def emit(self, record: logging.LogRecord) -> None:
        if record.name.startswith("websockets.client"):
            return  # the fuzzers' own clients (propagated to the root)
        if record.levelno >= logging.ERROR or record.exc_info:
            exc = record.exc_info[1] if record.exc_info else None
            detail = f": {type(exc).__name__}: {exc}" if exc is not None else ""
            self._note(f"{record.name}: {record.getMessage()}{detail}")

    def _thread_hook(self, args: threading.ExceptHookArgs) -> None:
        name = args.thread.name if args.thread else "?"
        self._note(f"thread {name}: {args.exc_type.__name__}: {args.exc_value}")

    def _unraisable(self, args: Any) -> None:
        self._note(f"unraisable: {args.exc_type.__name__}: {args.exc_value}")

    def __enter__(self) -> Watch:
        for name in _LOGGERS:
            logging.getLogger(name).addHandler(self)
        self._old_hook, threading.excepthook = threading.excepthook, self._thread_hook
        self._old_unraisable, sys.unraisablehook = sys.unraisablehook, self._unraisable
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        for name in _LOGGERS:
            logging.getLogger(name).removeHandler(self)
        threading.excepthook = self._old_hook
        sys.unraisablehook = self._old_unraisable
