"""The latest verdict over HTTP on localhost, for the plant's monitoring: ``/status``
(the status file's JSON) and ``/metrics`` (the Prometheus text format)."""

from __future__ import annotations

import json
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

__all__ = ["StatusServer", "prometheus_text"]


def prometheus_text(doc: dict) -> str:
    """A status document as Prometheus metrics (text exposition format 0.0.4)."""

    def label(v) -> str:
        return str(v).replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")

    def number(v) -> str:
        if v is None or v != v:
            return "NaN"
        if v in (float("inf"), float("-inf")):
            return "+Inf" if v > 0 else "-Inf"
        return repr(float(v))

    lines = [
        "# HELP inspect_validate_cycle Number of the latest committed watch cycle.",
        "# TYPE inspect_validate_cycle gauge",
        f"inspect_validate_cycle {doc['cycle']}",
        "# HELP inspect_validate_status 1 for the latest cycle's status.",
        "# TYPE inspect_validate_status gauge",
    ]
    for status in ("pass", "fail", "drift", "error"):
        lines.append(f'inspect_validate_status{{status="{status}"}} {int(doc["status"] == status)}')
    lines += [
        "# HELP inspect_validate_consecutive_failures Failed cycles in a row.",
        "# TYPE inspect_validate_consecutive_failures gauge",
        f"inspect_validate_consecutive_failures {doc['consecutive_failures']}",
        "# HELP inspect_validate_value Latest measured value per illumination, class or "
        "comparison and quantity (log_error: log10 of ε).",
        "# TYPE inspect_validate_value gauge",
    ]
    alarms = []
    for v in doc["values"]:
        labels = ",".join(
            f'{k}="{label(v[k])}"' for k in ("illumination", "kind", "name", "quantity")
        )
        lines.append(f"inspect_validate_value{{{labels}}} {number(v['value'])}")
        alarms.append(f"inspect_validate_alarm{{{labels}}} {int(v['alarm'])}")
    lines += [
        "# HELP inspect_validate_alarm 1 where the quantity's drift chart alarms.",
        "# TYPE inspect_validate_alarm gauge",
        *alarms,
    ]
    return "\n".join(lines) + "\n"


class StatusServer:
    """Serve the latest status document on ``127.0.0.1:port`` from a daemon thread
    (port 0: any free one, see :attr:`port`)."""

    def __init__(self, port: int):
        self.doc: dict | None = None
        server = self

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self):
                doc = server.doc
                if self.path.rstrip("/") not in ("/status", "/metrics"):
                    self._send(404, "text/plain", "not found: /status or /metrics\n")
                elif doc is None:
                    self._send(503, "text/plain", "no cycle committed yet\n")
                elif self.path.rstrip("/") == "/status":
                    from inspect_validate.report.jsonfile import json_ready

                    self._send(200, "application/json", json.dumps(json_ready(doc)) + "\n")
                else:
                    self._send(200, "text/plain; version=0.0.4", prometheus_text(doc))

            def _send(self, code, kind, text):
                body = text.encode()
                self.send_response(code)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args):  # the watch's own output is the log
                pass

        self.httpd = ThreadingHTTPServer(("127.0.0.1", port), Handler)
        self.port = self.httpd.server_address[1]
        threading.Thread(target=self.httpd.serve_forever, daemon=True).start()

    def close(self) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()
