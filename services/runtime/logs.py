"""Structured logging for services: one line per record, key=value fields, optional JSON.

Records never block the thread that logs them: `setup_logging` installs a handler that formats
the record and hands the line to a bounded `LineOutlet` on stderr, whose own thread writes it.
When stderr does not take output (a pipe nobody reads) lines are dropped and counted, and the
count is written once stderr takes output again.

Use `logging.getLogger(__name__).info("msg", extra={"fields": {"key": value}})` or the
`kv()` helper; `RateLimitedLog` keeps a noisy condition (bad payloads, overruns) to at most
one line per period per key while counting every occurrence.
"""

from __future__ import annotations

import atexit
import json
import logging
import sys
import threading
import time
from typing import Any

from services.runtime.outlet import LineOutlet

_SERVICE_NAME = "handover"


class _Formatter(logging.Formatter):
    def __init__(self, json_lines: bool) -> None:
        super().__init__()
        self.json_lines = json_lines

    def format(self, record: logging.LogRecord) -> str:
        fields: dict[str, Any] = getattr(record, "fields", None) or {}
        stamp = time.strftime("%H:%M:%S", time.localtime(record.created))
        stamp += f".{int(record.msecs):03d}"
        if self.json_lines:
            doc = {
                "t": record.created,
                "level": record.levelname.lower(),
                "service": _SERVICE_NAME,
                "logger": record.name,
                "msg": record.getMessage(),
                **fields,
            }
            if record.exc_info:
                doc["exc"] = self.formatException(record.exc_info)
            return json.dumps(doc, default=str)
        text = f"{stamp} {record.levelname:<7} {record.getMessage()}"
        if fields:
            text += " " + " ".join(f"{k}={_fmt(v)}" for k, v in fields.items())
        if record.exc_info:
            text += "\n" + self.formatException(record.exc_info)
        return text


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    text = str(value)
    return f'"{text}"' if (" " in text or not text) else text


class OutletHandler(logging.Handler):
    """Formats a record in the caller's thread and queues the line; never waits for I/O."""

    def __init__(self, outlet: LineOutlet) -> None:
        super().__init__()
        self.outlet = outlet

    def emit(self, record: logging.LogRecord) -> None:
        try:
            self.outlet.put(self.format(record) + "\n")
        except Exception:  # noqa: BLE001 - a bad format argument must not reach the caller (nor block it)
            self.outlet.put(f"unformattable log record from {record.name}: {record.msg!r}\n")


_STDERR_OUTLET: LineOutlet | None = None


def stderr_outlet() -> LineOutlet | None:
    """The process's non-blocking stderr (made once; flushed for up to 1 s at exit), or None
    when `sys.stderr` is not a file descriptor (an in-memory capture, as in some tests)."""
    global _STDERR_OUTLET
    if _STDERR_OUTLET is None:
        try:
            fd = sys.stderr.fileno()
        except (AttributeError, OSError, ValueError):
            return None
        _STDERR_OUTLET = LineOutlet(fd, name="stderr",
                                    drop_notice=f"{{n}} log line(s) of {_SERVICE_NAME} dropped: stderr was blocked\n")
        atexit.register(_STDERR_OUTLET.flush, 1.0)
    return _STDERR_OUTLET


def write_line(text: str, flush_s: float = 0.0) -> None:
    """Write one line to stderr without blocking (dropped and counted if it cannot go);
    `flush_s` > 0 then waits up to that long for it to be written (exit paths only)."""
    line = text if text.endswith("\n") else text + "\n"
    outlet = stderr_outlet()
    if outlet is None:
        sys.stderr.write(line)
        return
    outlet.put(line)
    if flush_s > 0:
        outlet.flush(flush_s)


def setup_logging(service: str, level: str = "info", json_lines: bool = False) -> None:
    """Configure the root logger for a service process: one line per record to stderr,
    through a bounded non-blocking queue (see the module docstring)."""
    global _SERVICE_NAME
    _SERVICE_NAME = service
    outlet = stderr_outlet()
    handler: logging.Handler = OutletHandler(outlet) if outlet is not None else logging.StreamHandler(sys.stderr)
    handler.setFormatter(_Formatter(json_lines))
    root = logging.getLogger()
    root.handlers[:] = [handler]
    try:
        root.setLevel(level.upper())
    except ValueError:
        root.setLevel(logging.INFO)
        root.warning("unknown log level %r, using info", level)


def kv(**fields: Any) -> dict[str, Any]:
    """`extra=` argument carrying structured fields: ``log.info("x", extra=kv(a=1))``."""
    return {"fields": fields}


class RateLimitedLog:
    """Logs a condition at most once per `period_s` per key, counting every occurrence.

    Thread-safe; cheap enough to call from a Zenoh callback (no I/O unless it logs).
    """

    def __init__(self, logger: logging.Logger, period_s: float = 1.0) -> None:
        self._logger = logger
        self._period_s = period_s
        self._lock = threading.Lock()
        self._last_logged: dict[str, float] = {}
        self._suppressed: dict[str, int] = {}
        self.counts: dict[str, int] = {}

    def warning(self, key: str, message: str, **fields: Any) -> None:
        self.log(logging.WARNING, key, message, **fields)

    def info(self, key: str, message: str, **fields: Any) -> None:
        self.log(logging.INFO, key, message, **fields)

    def log(self, level: int, key: str, message: str, **fields: Any) -> None:
        """Log `message` at `level` unless `key` was logged less than `period_s` ago (then it
        is counted, and the count goes with the next line that is logged)."""
        now = time.monotonic()
        with self._lock:
            self.counts[key] = self.counts.get(key, 0) + 1
            last = self._last_logged.get(key)
            if last is not None and now - last < self._period_s:
                self._suppressed[key] = self._suppressed.get(key, 0) + 1
                return
            suppressed = self._suppressed.pop(key, 0)
            self._last_logged[key] = now
        if suppressed:
            fields["suppressed"] = suppressed
        self._logger.log(level, message, extra=kv(**fields))
