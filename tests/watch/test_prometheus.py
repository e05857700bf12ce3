"""The monitoring the manual ships (docs/monitoring/): its alerting rules tested by
promtool on the metrics of real watches (silent on a good station, firing on a drifted
one, on one that stopped cycling and on one that is gone), and a real Prometheus server
scraping a running simulated `watch`, evaluating the rules, and answering the Grafana
dashboard's queries.

Prometheus and promtool are Debian's ``prometheus`` package (`.ci/run` installs it);
without them these tests are skipped, saying so.
"""

import json
import re
import shutil
import socket
import subprocess
import sys
import time
import urllib.parse
import urllib.request
from pathlib import Path

import pytest
import yaml
from conftest import ROOT, copy_station

from inspect_validate.camera.health import COUNTERS, HEALTH

MONITORING = ROOT / "docs" / "monitoring"
RULES = MONITORING / "inspect-validate.rules.yml"
needs_prometheus = pytest.mark.skipif(
    not (shutil.which("prometheus") and shutil.which("promtool")),
    reason="Debian's prometheus package is not installed (.ci/run installs it)",
)
SAMPLE = re.compile(r"^(?P<name>[a-z_]+)(?P<labels>\{.*\})? (?P<value>\S+)$")


def _watched_metrics(cli, tmp_path, name, golden, world, cycles, *, camera=None, codes=(0, 1)):
    """The /metrics text of each of ``cycles`` cycles of a real watch (one cycle per
    invocation, continuing its history: the status file after each, as /metrics serves
    it); ``camera``: keys of the station's camera block to set."""
    from inspect_validate.watch.serve import prometheus_text

    (tmp_path / name).mkdir()
    path = copy_station(tmp_path / name, world=world)
    if camera:
        doc = yaml.safe_load(path.read_text())
        doc["camera"].update(camera)
        path.write_text(yaml.safe_dump(doc, sort_keys=False))
    texts = []
    for _ in range(cycles):
        folder = tmp_path / name
        args = ["--db", folder / "h.sqlite", "--status", folder / "status.json"]
        code, out, err = cli(
            ["watch", path, "--golden", golden, *args, "--interval", 0, "--cycles", 1]
        )
        assert code in codes, out + err
        doc = json.loads((tmp_path / name / "status.json").read_text())
        texts.append(prometheus_text(doc))
    return texts


#: How the rules' summaries name the camera of a station of several.
CAMERA = "{{ with $labels.camera }} camera {{ . }}{{ end }}"


def chart_series(texts, instance, *, clock=60.0):
    """promtool input series of one instance: every sample line of each cycle's metrics,
    one value a minute; the cycle timestamps on the test's clock (cycle k at k minutes,
    the interval 60 s) instead of the wall clock."""
    values: dict[str, list[str]] = {}
    for k, text in enumerate(texts):
        for line in text.splitlines():
            m = SAMPLE.match(line)
            if not m:
                continue
            labels = m["labels"][1:-1] if m["labels"] else ""
            labels = ",".join(
                x for x in (labels, f'job="inspect-validate",instance="{instance}"') if x
            )
            key = f"{m['name']}{{{labels}}}"
            value = m["value"]
            if m["name"] == "inspect_validate_cycle_timestamp_seconds":
                value = f"{k * clock:g}"
            elif m["name"] == "inspect_validate_cycle_interval_seconds":
                value = f"{clock:g}"
            values.setdefault(key, []).append(value)
    series = [{"series": key, "values": " ".join(v)} for key, v in values.items()]
    series.append(
        {
            "series": f'up{{job="inspect-validate",instance="{instance}"}}',
            "values": " ".join(["1"] * len(texts)),
        }
    )
    return series


def _alarms(text):
    return [
        dict(re.findall(r'(\w+)="([^"]*)"', m["labels"]))
        for line in text.splitlines()
        if (m := SAMPLE.match(line)) and m["name"] == "inspect_validate_alarm" and m["value"] == "1"
    ]


@needs_prometheus
@pytest.mark.slow
def test_the_alerting_rules_fire_on_a_drifted_world_and_stay_silent_on_a_good_one(
    cli, tmp_path, golden
):
    good = _watched_metrics(cli, tmp_path, "good", golden, None, 8)
    drifted = _watched_metrics(
        cli, tmp_path, "drifted", golden, {"changes": [{"start": 2, "irradiance": {1: 0.95}}]}, 8
    )
    alarms = _alarms(drifted[-1])
    assert alarms and {a["illumination"] for a in alarms} == {"amber"}
    assert not _alarms(good[-1]) and '{status="pass"} 1' in good[-1]
    # A watch that stops cycling after its third cycle (its /metrics still answering),
    # and one that is gone (its scrapes fail).
    stopped = good[:3] + [good[2]] * 5
    series = (
        chart_series(good, "good")
        + chart_series(drifted, "drifted")
        + chart_series(stopped, "stopped")
    )
    for s in series:
        if (
            s["series"].startswith("inspect_validate_cycle_timestamp_seconds")
            and "stopped" in s["series"]
        ):
            s["values"] = "0 60 120 120 120 120 120 120"
    series.append(
        {"series": 'up{job="inspect-validate",instance="gone"}', "values": "1 1 0 0 0 0 0 0"}
    )

    def alert(instance, severity, summary, description, **labels):
        return {
            "exp_labels": {
                "severity": severity,
                "job": "inspect-validate",
                "instance": instance,
                **labels,
            },
            "exp_annotations": {"summary": summary, "description": description},
        }

    drift_alerts = [
        alert(
            "drifted",
            "warning",
            f"drifted: {a['illumination']} {a['name']} {a['quantity']} drifted from its golden statistics",
            "The EWMA drift chart left its band; see /status for the likely cause.",
            **{k: a[k] for k in ("illumination", "kind", "name", "quantity")},
        )
        for a in alarms
    ]
    tests = {
        "rule_files": [str(RULES)],
        "evaluation_interval": "1m",
        "tests": [
            {
                "interval": "1m",
                "input_series": series,
                "alert_rule_test": [
                    {"eval_time": "7m", "alertname": "InspectionDrift", "exp_alerts": drift_alerts},
                    {"eval_time": "7m", "alertname": "InspectionFailing", "exp_alerts": []},
                    {"eval_time": "7m", "alertname": "InspectionDeviceErrors", "exp_alerts": []},
                    {
                        "eval_time": "7m",
                        "alertname": "InspectionStalled",
                        "exp_alerts": [
                            alert(
                                "stopped",
                                "critical",
                                "stopped: no watch cycle for 5m 0s",
                                "The latest committed cycle is more than three intervals (at least three minutes) old.",
                            )
                        ],
                    },
                    {"eval_time": "3m", "alertname": "InspectionWatchDown", "exp_alerts": []},
                    {
                        "eval_time": "5m",
                        "alertname": "InspectionWatchDown",
                        "exp_alerts": [
                            alert(
                                "gone",
                                "critical",
                                "gone: the watch's /metrics does not answer",
                                "inspect-validate watch is not running (or not reachable on its --http port).",
                            )
                        ],
                    },
                ],
            }
        ],
    }
    path = tmp_path / "rules_test.yml"
    path.write_text(yaml.safe_dump(tests, sort_keys=False, allow_unicode=True))
    result = subprocess.run(
        ["promtool", "test", "rules", str(path)], capture_output=True, text=True
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert "SUCCESS" in result.stdout


@needs_prometheus
@pytest.mark.slow
def test_the_camera_rules_fire_on_a_lossy_deaf_flaky_camera_and_stay_silent_on_a_good_one(
    cli, tmp_path, golden
):
    """The issue's end to end for watch: each cycle's health summed over the history and
    exported as Prometheus counters; promtool fires the camera rules on a world whose
    link starts losing packets and whose camera starts ignoring triggers at cycle 1 and
    drops out for cycles 2–4 (each cycle after an error one counted as a reconnect,
    across restarts of the watch), and none on a good world."""
    good = _watched_metrics(cli, tmp_path, "good", golden, None, 6)
    changes = [
        {"start": 1, "packet_loss": 0.002, "missed_trigger_every": 4},
        {"start": 2, "stop": 5, "camera_timeout": True},
    ]
    bad = _watched_metrics(
        cli,
        tmp_path,
        "bad",
        golden,
        {"changes": changes},
        6,
        camera={"timeout_s": 0.3},
        codes=(0, 1, 3),
    )
    assert "inspect_validate_camera_frames_incomplete_total 0.0" in good[-1]
    assert "inspect_validate_camera_packets_lost_total" not in good[-1]  # not offered
    assert "inspect_validate_reconnects_total" not in good[-1]
    assert "inspect_validate_reconnects_total 3.0" in bad[-1]
    rules = {r["alert"]: r for r in yaml.safe_load(RULES.read_text())["groups"][0]["rules"]}

    def fired(name, instance):
        annotations = rules[name]["annotations"]
        return {
            "exp_labels": {
                "severity": "warning",
                "job": "inspect-validate",
                "instance": instance,
            },
            "exp_annotations": {
                "summary": annotations["summary"]
                .replace("{{ $labels.instance }}", instance)
                .replace(CAMERA, ""),  # a station of one camera has no camera label
                "description": annotations["description"],
            },
        }

    tests = {
        "rule_files": [str(RULES)],
        "evaluation_interval": "1m",
        "tests": [
            {
                "interval": "1m",
                "input_series": chart_series(good, "good") + chart_series(bad, "bad"),
                "alert_rule_test": [
                    {"eval_time": "5m", "alertname": name, "exp_alerts": [fired(name, "bad")]}
                    for name in (
                        "CameraFramesIncomplete",
                        "CameraMissedTriggers",
                        "InspectionReconnecting",
                    )
                ]
                + [
                    # the simulated camera has no packets to lose: the rule has no series
                    {"eval_time": "5m", "alertname": "CameraPacketsLost", "exp_alerts": []},
                    # before the link degraded, nothing
                    {"eval_time": "0m", "alertname": "CameraFramesIncomplete", "exp_alerts": []},
                ],
            }
        ],
    }
    path = tmp_path / "rules_test.yml"
    path.write_text(yaml.safe_dump(tests, sort_keys=False, allow_unicode=True))
    result = subprocess.run(
        ["promtool", "test", "rules", str(path)], capture_output=True, text=True
    )
    assert result.returncode == 0, result.stdout + result.stderr


@pytest.mark.skipif(not shutil.which("promtool"), reason="promtool is not installed")
def test_the_light_field_rule_fires_on_a_field_chart_alone(tmp_path):
    """promtool's unit test of the rule: a field chart's alarm fires it naming the class
    and the slope; a class mean's alarm (a light that dims) does not."""
    rule = next(
        r for r in yaml.safe_load(RULES.read_text())["groups"][0]["rules"]
        if r["alert"] == "InspectionLightField"
    )  # fmt: skip
    labels = 'job="inspect-validate",instance="line",illumination="amber",name="A"'
    tests = {
        "rule_files": [str(RULES)],
        "evaluation_interval": "1m",
        "tests": [
            {
                "interval": "1m",
                "input_series": [
                    {
                        "series": f'inspect_validate_alarm{{{labels},kind="field",quantity="slope_y"}}',
                        "values": "0 0 1 1 1",
                    },
                    {
                        "series": f'inspect_validate_alarm{{{labels},kind="class",quantity="mean"}}',
                        "values": "1 1 1 1 1",
                    },
                ],
                "alert_rule_test": [
                    {"eval_time": "1m", "alertname": "InspectionLightField", "exp_alerts": []},
                    {
                        "eval_time": "3m",
                        "alertname": "InspectionLightField",
                        "exp_alerts": [
                            {
                                "exp_labels": {
                                    "severity": "warning",
                                    "job": "inspect-validate",
                                    "instance": "line",
                                    "illumination": "amber",
                                    "name": "A",
                                    "kind": "field",
                                    "quantity": "slope_y",
                                },
                                "exp_annotations": {
                                    "summary": "line: the light's field over A changed (slope_y)",
                                    "description": rule["annotations"]["description"],
                                },
                            }
                        ],
                    },
                ],
            }
        ],
    }
    path = tmp_path / "rules_test.yml"
    path.write_text(yaml.safe_dump(tests, sort_keys=False, allow_unicode=True))
    result = subprocess.run(
        ["promtool", "test", "rules", str(path)], capture_output=True, text=True
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_rules_and_the_dashboard_are_valid(tmp_path):
    """Ten rules load (promtool, where installed); the dashboard is Grafana JSON whose
    every panel queries a metric the watch exports."""
    from inspect_validate.watch.serve import prometheus_text

    if shutil.which("promtool"):
        result = subprocess.run(
            ["promtool", "check", "rules", str(RULES)], capture_output=True, text=True
        )
        assert result.returncode == 0 and "SUCCESS: 10 rules found" in result.stdout, result.stdout
    dashboard = json.loads((MONITORING / "grafana-dashboard.json").read_text())
    exported = set(
        re.findall(
            r"^# TYPE (\w+)",
            prometheus_text(
                {
                    "cycle": 1,
                    "status": "pass",
                    "consecutive_failures": 0,
                    "values": [],
                    "health": dict.fromkeys(HEALTH, 1.0),
                    "health_totals": dict.fromkeys([*COUNTERS, "reconnects"], 1.0),
                }
            ),
            re.M,
        )
    )
    used = {
        name
        for p in dashboard["panels"]
        for t in p["targets"]
        for name in re.findall(r"\b(inspect_validate_\w+)", t["expr"])
    }
    assert used and used <= exported, used - exported
    assert dashboard["uid"] and dashboard["schemaVersion"] >= 30


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _query(port, expr):
    url = f"http://127.0.0.1:{port}/api/v1/query?" + urllib.parse.urlencode({"query": expr})
    doc = json.loads(urllib.request.urlopen(url, timeout=5).read())
    assert doc["status"] == "success", doc
    return doc["data"]["result"]


def _until(what, timeout=60.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            value = what()
        except OSError:
            value = None
        if value:
            return value
        time.sleep(0.5)
    raise AssertionError(f"not within {timeout:g} s: {what.__doc__}")


@needs_prometheus
@pytest.mark.slow
def test_a_real_prometheus_scrapes_a_running_watch_and_fires_its_drift_alert(tmp_path, golden):
    path = copy_station(
        tmp_path,
        world={"temperature_c": 41.5, "changes": [{"start": 4, "irradiance": {1: 0.95}}]},
    )
    args = ["--db", tmp_path / "w" / "h.sqlite", "--interval", 0.5, "--cycles", 400, "--http", 0]
    argv = [sys.executable, "-m", "inspect_validate", "watch", path, "--golden", golden, *args]
    watch = subprocess.Popen(
        [str(a) for a in argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    prometheus = None
    try:
        line = _until(lambda: watch.stdout.readline())
        watch_port = int(re.search(r"127\.0\.0\.1:(\d+)/status", line)[1])
        port = _free_port()
        shutil.copy(RULES, tmp_path / RULES.name)
        config = {
            "global": {"scrape_interval": "1s", "evaluation_interval": "1s"},
            "rule_files": [RULES.name],
            "scrape_configs": [
                {
                    "job_name": "inspect-validate",
                    "static_configs": [{"targets": [f"127.0.0.1:{watch_port}"]}],
                }
            ],
        }
        (tmp_path / "prometheus.yml").write_text(yaml.safe_dump(config))
        options = {
            "config.file": tmp_path / "prometheus.yml",
            "storage.tsdb.path": tmp_path / "tsdb",
            "web.listen-address": f"127.0.0.1:{port}",
        }
        prometheus = subprocess.Popen(
            ["prometheus", *(f"--{k}={v}" for k, v in options.items())],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            cwd=tmp_path,
        )

        def scraped():
            """Prometheus has scraped a committed cycle."""
            return _query(port, "inspect_validate_cycle >= 2")

        _until(scraped)
        status = json.loads(urllib.request.urlopen(f"http://127.0.0.1:{watch_port}/status").read())
        (cycle,) = _query(port, "inspect_validate_cycle")
        assert 0 <= status["cycle"] - float(cycle["value"][1]) <= 10  # a scrape or two behind
        (up,) = _query(port, 'up{job="inspect-validate"}')
        assert up["value"][1] == "1"
        means = _query(port, 'inspect_validate_value{kind="class",quantity="mean"}')
        assert len(means) == 6  # 2 illuminations × 3 classes, as /status has them

        def firing():
            """the drift alert fires"""
            return _query(port, 'ALERTS{alertname="InspectionDrift",alertstate="firing"}')

        alerts = _until(firing, timeout=90)
        assert {a["metric"]["illumination"] for a in alerts} == {"amber"}
        assert not _query(port, 'ALERTS{alertname=~"InspectionFailing|InspectionStalled"}')
        # Every query of the dashboard is valid PromQL, and every panel has data behind it
        # (of the camera's losses, those the simulated camera offers: no packets, and no
        # reconnects on a watch without errors).
        dashboard = json.loads((MONITORING / "grafana-dashboard.json").read_text())
        for panel in dashboard["panels"]:
            if panel["type"] == "table" and "alarm" not in panel["targets"][0]["expr"]:
                continue
            exprs = [
                t["expr"].replace("$instance", ".*").replace("$camera", ".*")
                for t in panel["targets"]
            ]

            def answered(exprs=exprs):
                """the panel's queries answer (increase() needs two scrapes)"""
                return [bool(_query(port, expr)) for expr in exprs]

            _until(lambda answered=answered: any(answered()), timeout=30)
            if "lost on the way" not in panel["title"]:
                assert all(answered()), panel["title"]
    finally:
        watch.terminate()
        watch.wait(timeout=30)
        watch.stdout.close()
        if prometheus is not None:
            prometheus.terminate()
            prometheus.wait(timeout=30)
    assert Path(tmp_path / "w" / "h.sqlite").exists()
