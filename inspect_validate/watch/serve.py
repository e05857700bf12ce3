"""The latest verdict over HTTP on localhost, for the plant's monitoring: ``/status``
(the status file's JSON) and ``/metrics`` (the Prometheus text format).

Only what a local scraper needs, and bounded against a hostile client: requests whose
``Host`` is not this machine's loopback address are refused (a page in the operator's
browser could otherwise read ``/status`` through DNS rebinding); a connection gets
:data:`TIMEOUT_S` to send at most :data:`MAX_REQUEST_BYTES` of request, and at most
:data:`MAX_CONNECTIONS` are served at once (more are closed at once), so idle or
half-sent requests hold neither threads nor memory; a client that leaves early is
not an error on ``watch``'s terminal.
"""

from __future__ import annotations

import contextlib
import json
import socket
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import urlsplit

__all__ = ["MAX_CONNECTIONS", "MAX_REQUEST_BYTES", "TIMEOUT_S", "StatusServer", "prometheus_text"]

TIMEOUT_S = 5.0
MAX_REQUEST_BYTES = 16 * 1024
MAX_CONNECTIONS = 16


def prometheus_text(doc: dict) -> str:
    """A status document as Prometheus metrics (text exposition format 0.0.4)."""

    lines = [
        "# HELP inspect_validate_info The station watched (its file), always 1.",
        "# TYPE inspect_validate_info gauge",
        f'inspect_validate_info{{station="{_label(doc.get("station", ""))}"}} 1',
        "# HELP inspect_validate_cycle Number of the latest committed watch cycle.",
        "# TYPE inspect_validate_cycle gauge",
        f"inspect_validate_cycle {doc['cycle']}",
        "# HELP inspect_validate_cycle_timestamp_seconds When the latest committed cycle "
        "started (Unix time).",
        "# TYPE inspect_validate_cycle_timestamp_seconds gauge",
        f"inspect_validate_cycle_timestamp_seconds {_number(doc.get('time'))}",
        "# HELP inspect_validate_cycle_interval_seconds The watch's interval between cycle "
        "starts (--interval).",
        "# TYPE inspect_validate_cycle_interval_seconds gauge",
        f"inspect_validate_cycle_interval_seconds {_number(doc.get('interval_s'))}",
        "# HELP inspect_validate_status 1 for the latest cycle's status.",
        "# TYPE inspect_validate_status gauge",
    ]
    for status in ("pass", "fail", "drift", "error"):
        lines.append(f'inspect_validate_status{{status="{status}"}} {int(doc["status"] == status)}')
    lines += [
        "# HELP inspect_validate_consecutive_failures Failed cycles in a row.",
        "# TYPE inspect_validate_consecutive_failures gauge",
        f"inspect_validate_consecutive_failures {doc['consecutive_failures']}",
    ]
    lines += _health_lines(doc)
    series = {
        "value": "Latest measured value per illumination, class or comparison and quantity "
        "(mean DN, variance DN², snr_db dB, log_error: log10 of ε).",
        "ewma": "The quantity's drift chart: its smoothed value (EWMA).",
        "band_low": "The drift chart's lower limit.",
        "band_high": "The drift chart's upper limit.",
        "alarm": "1 where the quantity's drift chart alarms.",
    }
    keys = {"value": "value", "ewma": "ewma", "band_low": "low", "band_high": "high"}
    rows: dict[str, list[str]] = {name: [] for name in series}
    for v in doc["values"]:
        labels = ",".join(
            f'{k}="{_label(v[k])}"'
            for k in ("camera", "illumination", "kind", "name", "quantity")
            if k in v  # a camera of several is named
        )
        for name, key in keys.items():
            if key in v:
                rows[name].append(f"inspect_validate_{name}{{{labels}}} {_number(v[key])}")
        rows["alarm"].append(f"inspect_validate_alarm{{{labels}}} {int(v['alarm'])}")
    for name, text in series.items():
        lines += [
            f"# HELP inspect_validate_{name} {text}",
            f"# TYPE inspect_validate_{name} gauge",
            *rows[name],
        ]
    return "\n".join(lines) + "\n"


def _label(v) -> str:
    return str(v).replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")


def _number(v) -> str:
    if v is None or v != v:
        return "NaN"
    if v in (float("inf"), float("-inf")):
        return "+Inf" if v > 0 else "-Inf"
    return repr(float(v))


def _health_lines(doc: dict) -> list[str]:
    """The camera's health: its counters summed over the history as Prometheus counters
    (``inspect_validate_camera_<name>_total``; the watch's reconnects as
    ``inspect_validate_reconnects_total``), and the latest cycle's gauges
    (``inspect_validate_camera_temperature_celsius``, ``…_link_speed_mbps``). A quantity
    the camera does not offer is not exported: absent, never 0. On a station of several
    cameras each camera's carry its name as the label ``camera``."""
    from inspect_validate.camera.health import QUANTITIES
    from inspect_validate.watch.history import RECONNECTS

    counters = [
        (q.name, q.metric, f"The camera's {q.name.replace('_', ' ')}")
        for q in QUANTITIES
        if q.kind == "counter"
    ]
    counters.append((RECONNECTS, "inspect_validate_reconnects_total", "Reconnects"))
    helps = {q.name: q.meaning for q in QUANTITIES}
    helps[RECONNECTS] = "cycles that reopened the devices after an error cycle"
    from inspect_validate.watch.history import health_rows

    def samples(health: dict, name: str, metric: str) -> list[str]:
        return [
            f'{metric}{{camera="{_label(camera)}"}} {_number(v)}'
            if camera
            else f"{metric} {_number(v)}"
            for camera, q, v in health_rows(health)
            if q == name
        ]

    lines = []
    totals = doc.get("health_totals") or {}
    for name, metric, what in counters:
        rows = samples(totals, name, metric)
        if rows:
            lines += [
                f"# HELP {metric} {what} over the history: {helps[name]}.",
                f"# TYPE {metric} counter",
                *rows,
            ]
    health = doc.get("health") or {}
    for gauge in (q for q in QUANTITIES if q.kind == "gauge"):
        metric = gauge.metric
        rows = samples(health, gauge.name, metric)
        if rows:
            lines += [
                f"# HELP {metric} The latest cycle's reading: {gauge.meaning}.",
                f"# TYPE {metric} gauge",
                *rows,
            ]
    return lines


class _Budget:
    """The request stream, ending (as if the client had closed) once the request has
    used its bytes or its time: the standard library alone allows 100 header lines of
    64 KB, sent as slowly as the client likes."""

    def __init__(self, raw) -> None:
        self.raw, self.left = raw, MAX_REQUEST_BYTES
        self.deadline = time.monotonic() + TIMEOUT_S
        self.cut: int | None = None  # the HTTP status for a request cut short

    def readline(self, limit=-1):
        remaining = self.deadline - time.monotonic()
        if self.left <= 0 or remaining <= 0:
            self.cut = 431 if self.left <= 0 else 408
            return b""
        line = self.raw.readline(min(self.left, limit) if limit >= 0 else self.left)
        self.left -= len(line)
        return line

    def __getattr__(self, name):
        return getattr(self.raw, name)


class _Server(ThreadingHTTPServer):
    daemon_threads = True

    def __init__(self, address, handler) -> None:
        self.slots = threading.BoundedSemaphore(MAX_CONNECTIONS)
        super().__init__(address, handler)

    def process_request(self, request, client_address) -> None:
        if not self.slots.acquire(blocking=False):
            self.shutdown_request(request)  # full: closed at once, no thread
            return
        super().process_request(request, client_address)

    def process_request_thread(self, request, client_address) -> None:
        try:
            super().process_request_thread(request, client_address)
        finally:
            self.slots.release()

    def handle_error(self, request, client_address) -> None:
        pass  # a client that left early or timed out; the scraper retries


class StatusServer:
    """Serve the latest status document on ``127.0.0.1:port`` from a daemon thread
    (port 0: any free one, see :attr:`port`).

    Raises
    ------
    OSError
        The port cannot be bound (in use, or privileged).
    """

    def __init__(self, port: int) -> None:
        self.doc: dict | None = None
        server = self

        class Handler(BaseHTTPRequestHandler):
            timeout = TIMEOUT_S  # an idle connection is closed after this

            def setup(self) -> None:
                super().setup()
                self.budget = _Budget(self.rfile)
                self.rfile = self.budget  # type: ignore[assignment]  # reads as the stream does
                # The socket's timeout is per read: a request trickled a byte at a time
                # would outlast it. Past its time the connection is shut, mid-read too.
                self.watchdog = threading.Timer(TIMEOUT_S, self._shut)
                self.watchdog.daemon = True
                self.watchdog.start()

            def _shut(self) -> None:
                with contextlib.suppress(OSError):
                    self.connection.shutdown(socket.SHUT_RDWR)

            def finish(self) -> None:
                self.watchdog.cancel()
                with contextlib.suppress(OSError):
                    super().finish()

            def version_string(self) -> str:
                return "inspect-validate"  # not the Python version

            def do_GET(self) -> None:
                doc = server.doc
                path = urlsplit(self.path).path.rstrip("/")
                host = self.headers.get("Host")
                if self.budget.cut:
                    self._send(
                        self.budget.cut, "text/plain", "refused: request too large or slow\n"
                    )
                elif host is not None and host.lower() not in server.hosts:
                    self._send(403, "text/plain", "refused: Host must be this machine's loopback\n")
                elif path not in ("/status", "/metrics"):
                    self._send(404, "text/plain", "not found: /status or /metrics\n")
                elif doc is None:
                    self._send(503, "text/plain", "no cycle committed yet\n")
                elif path == "/status":
                    from inspect_validate.files import json_ready

                    self._send(200, "application/json", json.dumps(json_ready(doc)) + "\n")
                else:
                    self._send(200, "text/plain; version=0.0.4", prometheus_text(doc))

            def _send(self, code, kind, text) -> None:
                body = text.encode()
                self.send_response(code)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args) -> None:  # the watch's own output is the log
                pass

        self.httpd = _Server(("127.0.0.1", port), Handler)
        self.port = self.httpd.server_address[1]
        self.hosts = {f"{name}:{self.port}" for name in ("127.0.0.1", "localhost")}
        threading.Thread(target=self.httpd.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
