"""`inspect-validate devices`: the cameras and controllers this machine can reach, and
what a camera offers a station file."""

from __future__ import annotations

import click

from inspect_validate.cli.common import ADDRESS, PATH


@click.command()
@click.option(
    "--cti", type=PATH, help="A GenTL producer (.cti) to load besides GENICAM_GENTL64_PATH's."
)
@click.option(
    "--backend",
    "only",
    multiple=True,
    help="Ask only this camera backend (repeatable; default: every installed one).",
)
@click.option(
    "--features",
    "serial",
    metavar="SERIAL",
    help="Open the camera with this serial number (or device id) and list what it offers: "
    "pixel formats, exposure and gain ranges, triggers, lines, chunks, and the health "
    "counters and gauges it reports.",
)
@click.option(
    "--port",
    "ports",
    multiple=True,
    type=ADDRESS,
    help="A port to list besides the system's serial ports: a device path or a "
    "controller's socket://host:port (repeatable).",
)
@click.option(
    "--probe",
    is_flag=True,
    help="Ask every port whether a light controller answers (Gardasoft RT, or --protocol's).",
)
@click.option(
    "--protocol",
    type=PATH,
    help="YAML of a generic ASCII controller's protocol (the keys of a station file's "
    "controller.protocol) to probe the ports with: its init and status commands.",
)
@click.option(
    "--json",
    "json_path",
    type=PATH,
    help="Also write what was found as JSON ('-': to stdout only).",
)
def devices(cti, only, serial, ports, probe, protocol, json_path):
    """List the cameras every installed backend can see and the serial ports.

    Each camera with its backend, vendor, model, serial number, user id, interface,
    whether another program holds it, and the station file's camera keys that choose
    it. A backend whose library is missing is listed with what to install. Nothing is
    set on any device; --probe sends each port an identification query. Exits 3 when
    --features names a camera that is not found or cannot be opened.
    """
    import json
    from dataclasses import asdict, fields

    from inspect_validate.camera.inventory import read_features, take_inventory
    from inspect_validate.camera.registry import Search, backend
    from inspect_validate.camera.settings import AsciiProtocol
    from inspect_validate.config import load_yaml
    from inspect_validate.errors import DeviceError
    from inspect_validate.files import atomic_write

    asked = load_yaml(protocol, AsciiProtocol, what="controller protocol") if protocol else None
    inventory = take_inventory(
        Search(cti=str(cti) if cti else None),
        only=only or None,
        ports=ports,
        probe=probe or asked is not None,
        protocol=asked,
    )
    features = None
    if serial is not None:
        match = [c for c in inventory.cameras if serial in (c.serial, c.device_id)]
        if not match:
            listing = ", ".join(f"{c.describe()} [{c.backend}]" for c in inventory.cameras)
            raise DeviceError(
                f"no camera with serial or id {serial!r} found; found: {listing or 'none'}"
            )
        chosen = match[0]
        features = (chosen, read_features(chosen))

    doc = {
        "cameras": [
            {
                **{f.name: getattr(c, f.name) for f in fields(c) if f.name != "key"},
                "station": {"backend": c.backend, **backend("cameras", c.backend).device_keys(c)},
            }
            for c in inventory.cameras
        ],
        "unavailable": inventory.unavailable,
        "without_discovery": list(inventory.without_discovery),
        "ports": [asdict(p) for p in inventory.ports],
    }
    if features is not None:
        info, offered = features
        doc["features"] = {
            "camera": info.describe(),
            "backend": info.backend,
            **asdict(offered),
            "monochrome": list(offered.monochrome),
            "bit_depth": offered.bit_depth,
        }
    if json_path is not None:
        text = json.dumps(doc, indent=2, default=str)
        if str(json_path) == "-":
            click.echo(text)
            return
        atomic_write(json_path, (text + "\n").encode())
    click.echo(_text(doc))


def _text(doc: dict) -> str:
    from inspect_validate.text import render_table

    out = []
    cameras = doc["cameras"]
    if cameras:
        header = ["backend", "vendor", "model", "serial", "user id", "interface", "access"]
        rows = [
            [
                c["backend"],
                c["vendor"],
                c["model"],
                c["serial"] or "-",
                c["user_id"] or "-",
                c["interface"] or "-",
                c["access"] or "?",
            ]
            for c in cameras
        ]
        out += ["cameras", render_table(header, rows, left=set(range(len(header))))]
        out += ["", "station file keys (camera:):"]
        out += [
            f"  {c['vendor']} {c['model']} {c['serial']}: "
            + ", ".join(f"{k}: {v}" for k, v in c["station"].items())
            for c in cameras
        ]
    else:
        out.append("cameras: none found")
    for name, why in doc["unavailable"].items():
        out.append(f"{name}: cannot look: {why}")
    if doc["without_discovery"]:
        out.append(f"nothing to discover: {', '.join(doc['without_discovery'])}")
    out.append("")
    ports = doc["ports"]
    if ports:
        header = ["port", "description", "hardware id", "controller"]
        rows = [
            [
                p["device"],
                p["description"] or "-",
                p["hardware_id"] or "-",
                p["problem"]
                or ((p["answer"] or "no answer") if p["probed"] else "not probed (--probe)"),
            ]
            for p in ports
        ]
        out += ["serial ports", render_table(header, rows, left=set(range(len(header))))]
    else:
        out.append("serial ports: none found (give a controller's address with --port)")
    if "features" in doc:
        out += ["", *_features(doc["features"])]
    return "\n".join(out)


def _features(f: dict) -> list[str]:
    def span(r, unit):
        return f"{r[0]:g} – {r[1]:g} {unit}" if r else "not offered"

    def listed(xs):
        return ", ".join(xs) or "none"

    mono = listed(f["monochrome"]) + (f" (up to {f['bit_depth']} bit)" if f["bit_depth"] else "")
    size = f"{f['max_size'][0]} × {f['max_size'][1]} px" if f["max_size"] else "not readable"
    rows = [
        ("pixel formats", listed(f["pixel_formats"])),
        ("monochrome (pixel_format)", mono),
        ("exposure (exposure_us)", span(f["exposure_us"], "µs")),
        ("gain (gain_db)", span(f["gain_db"], "dB")),
        ("largest region", size),
        ("software trigger", "yes" if f["software_trigger"] else "no"),
        ("trigger selectors", listed(f["trigger_selectors"])),
        ("trigger sources", listed(f["trigger_sources"])),
        ("trigger lines (trigger_line)", listed(f["trigger_lines"])),
        ("lines", listed(f["lines"])),
        ("strobe lines (strobe_line)", listed(f["strobe_lines"])),
        ("chunks (chunks)", listed(f["chunks"])),
        ("health (acceptance.health)", listed(f["health"])),
    ]
    width = max(len(k) for k, _ in rows)
    return [f"{f['camera']} through {f['backend']} offers:"] + [
        f"  {k.ljust(width)}  {v}" for k, v in rows
    ]
