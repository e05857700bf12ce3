"""`inspect-validate rois`: regions proposed from a frame, imported from other tools'
annotations, and shown over a frame."""

from __future__ import annotations

from collections import Counter

import click

from inspect_validate.cli.common import PATH, SIZE, Number, retired_option


@click.group()
def rois():
    """Make, import and look at ROI files (which pixels belong to which class)."""


def _mean_frame(frames, dark):
    """The mean of FRAMES, the mean of --dark frames (or None), and the stack."""
    from inspect_validate.images import read_frames

    stack = read_frames(frames)
    darks = read_frames(dark) if dark else None
    if darks is not None and darks.shape[1:] != stack.shape[1:]:
        from inspect_validate.errors import InputError

        raise InputError(
            f"dark frames are {darks.shape[2]}×{darks.shape[1]}, the frames "
            f"{stack.shape[2]}×{stack.shape[1]}",
            source="--dark",
        )
    return stack.mean(axis=0), (None if darks is None else darks.mean(axis=0)), stack


def _write_picture(path, picture) -> None:
    import cv2

    from inspect_validate.errors import InputError

    if path.suffix.lower() not in (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp"):
        raise InputError("give a picture file (.png)", source=str(path))
    if not cv2.imwrite(str(path), picture):
        raise InputError(
            "cannot write the picture (folder missing or not writable)", source=str(path)
        )


@rois.command()
@click.argument("frames", nargs=-1, required=True, type=PATH)
@click.option("--out", type=PATH, required=True, help="The ROI file to write (YAML).")
@click.option(
    "--overlay", type=PATH, help="The numbered regions over the frame (default: OUT as .png)."
)
@click.option(
    "--names",
    help="Class names in the order of the regions' numbers (A,B,C), or NUMBER=NAME pairs as "
    "rois import takes (1=A,3=B); a name given twice merges those regions (default: 1, 2, …).",
)
@click.option(
    "--dark", multiple=True, type=PATH, help="Dark frames: what counts as unlit background."
)
@click.option(
    "--min-area",
    type=click.IntRange(min=1),
    help="Smallest region, px (default: 0.5 % of the frame).",
)
@click.option(
    "--margin",
    type=click.IntRange(min=0, max=100),
    default=2,
    show_default=True,
    help="Pixels kept clear of each region's edge.",
)
@click.option(
    "--edge",
    type=Number(min=0.5, max=100),
    default=4.0,
    show_default=True,
    help="An edge: a gradient above this many times its noise.",
)
@click.option("--force", is_flag=True, help="Overwrite OUT if it exists.")
def propose(frames, out, overlay, names, dark, min_area, margin, edge, force):
    """Find the uniform lit objects in FRAMES and write them as a draft ROI file.

    FRAMES are image files, or a capture step's folder (their mean is used: less noise,
    cleaner edges). Each region found becomes a class, numbered top to bottom and left
    to right on the overlay picture; give --names to name them (A,B,C) or rename the
    classes in the file. The file records the frame's size.
    """
    from inspect_validate.errors import InputError
    from inspect_validate.roi.overlay import draw_regions
    from inspect_validate.roi.propose import draft_rois, find_regions
    from inspect_validate.roi.roiset import write_rois
    from inspect_validate.text import render_table

    if out.exists() and not force:
        raise InputError(f"{out} exists; give --force to overwrite it", source="rois propose")
    image, dark_image, stack = _mean_frame(frames, dark)
    dark_level = None if dark_image is None else float(dark_image.mean())
    regions = find_regions(
        image, min_area=min_area, margin=margin, edge=edge, dark_level=dark_level
    )
    if not regions and stack.dtype.kind in "ui":
        import numpy as np

        top = np.iinfo(stack.dtype).max
        clipped = float(np.mean(stack >= top))
        if clipped > 0.5:  # nothing uniform to find in a clipped frame: say why
            raise InputError(
                f"no region found: {100 * clipped:.0f} % of the frame's pixels are saturated "
                f"({top} DN); lower the exposure or the light, and capture again",
                source=str(frames[0]),
            )
    listed = [n.strip() for n in names.split(",")] if names else None
    if listed is not None and not all(listed):
        raise click.BadParameter("an empty name; write e.g. A,B,C", param_hint="--names")
    paired = [n for n in listed or () if "=" in n]
    if listed is not None and paired:
        # LABEL=NAME pairs, as rois import takes them: the label is the region's number.
        if len(paired) != len(listed):
            raise click.BadParameter(
                "names in the regions' order (A,B,C) or NUMBER=NAME pairs (1=A,3=B), not both",
                param_hint="--names",
            )
        split = [tuple(part.strip() for part in n.split("=", 1)) for n in listed]
        if not all(label and name for label, name in split):
            raise click.BadParameter("an empty number or name in NUMBER=NAME", param_hint="--names")
        twice = sorted(n for n, count in Counter(lb for lb, _ in split).items() if count > 1)
        if twice:
            raise click.BadParameter(
                f"region {twice[0]} is named twice; give each region one name",
                param_hint="--names",
            )
        pairs = dict(split)
        unknown = sorted(set(pairs) - {str(r.number) for r in regions})
        if unknown:
            raise click.BadParameter(
                f"no region {', '.join(unknown)} (the regions are 1–{len(regions)})",
                param_hint="--names",
            )
        listed = [pairs.get(str(r.number), str(r.number)).strip() for r in regions]
    if listed is not None and regions and len(listed) != len(regions):
        raise click.BadParameter(
            f"{len(listed)} name{'s' if len(listed) != 1 else ''} for {len(regions)} regions; "
            "give one name per region, in the order of the overlay's numbers (a name twice "
            "merges those regions), or NUMBER=NAME pairs",
            param_hint="--names",
        )
    roiset = draft_rois(
        regions, frame=(image.shape[1], image.shape[0]), names=listed, source=str(frames[0])
    )
    write_rois(
        roiset,
        out,
        comment=f"Proposed by inspect-validate rois propose from {frames[0]}: check the "
        "overlay, name the classes as the scene does.",
    )
    picture = draw_regions(
        image,
        {str(r.number): r.mask for r in regions},
        labels={
            str(r.number): f"{r.number}" + (f" {listed[r.number - 1]}" if listed else "")
            for r in regions
        },
    )
    overlay = overlay or out.with_suffix(".png")
    _write_picture(overlay, picture)
    rows = [
        [
            str(r.number),
            (listed[r.number - 1] if listed else str(r.number)),
            str(r.pixels),
            f"{r.mean:.1f}",
            *([] if dark_image is None else [f"{r.mean - float(dark_image[r.mask].mean()):.1f}"]),
            f"{r.std:.2f}",
            type(r.shape).__name__.lower(),
        ]
        for r in regions
    ]
    above = [] if dark_image is None else ["μ − dark [DN]"]
    header = ["region", "class", "pixels", "μ [DN]", *above, "σ [DN]", "shape"]
    click.echo(render_table(header, rows))
    for warning in _propose_warnings(image, dark_image, regions, stack):
        click.echo(f"warning: {warning}", err=True)
    click.echo(f"ROI file: {out}\noverlay: {overlay}")


def _propose_warnings(image, dark_image, regions, stack) -> list[str]:
    """What makes proposed regions suspect: frames no brighter than the darks (the regions
    are then the sensor's or a test pattern's, not lit objects), regions that clip."""
    import numpy as np

    warnings = []
    if dark_image is not None:
        rise = float(image.mean() - dark_image.mean())
        noise = float(dark_image.std())
        if rise <= max(noise, 0.5):
            warnings.append(
                f"the frames are no brighter than the dark frames ({image.mean():.1f} against "
                f"{dark_image.mean():.1f} DN): no light reached the camera, and what was "
                "outlined is no lit object; check the light, the lens cap and the channel"
            )
    if stack.dtype.kind in "ui":
        top = np.iinfo(stack.dtype).max
        for r in regions:
            clipped = float(np.mean(stack[:, r.mask] >= top))
            if clipped > 0.001:
                warnings.append(
                    f"region {r.number}: {100 * clipped:.1f} % of its pixels saturated "
                    f"({top} DN): lower the exposure or the light before measuring it"
                )
    return warnings


@rois.command()
@click.argument("frames", nargs=-1, required=True, type=PATH)
@click.option(
    "--rois",
    "roi_file",
    type=PATH,
    help="ROI file: YAML, ImageJ .roi or RoiSet.zip (as measure's).",
)
@click.option("--out", type=PATH, required=True, help="The picture to write (.png).")
@click.option("--dark", multiple=True, type=PATH, help="Dark frames, subtracted before μ and σ.")
def show(frames, roi_file, out, dark):
    """Draw the --rois file's classes over FRAMES (their mean) and list each class's pixels,
    μ and σ.

    σ is over every pixel of the class in every frame: the spread a measurement of it
    sees. A class far wider than the others, or one whose outline crosses an object's
    edge, is what to look for.
    """
    import numpy as np

    from inspect_validate.roi import class_masks, read_rois
    from inspect_validate.roi.overlay import draw_regions
    from inspect_validate.text import render_table

    if roi_file is None:  # the ROI file first, as this command took it before --rois
        if len(frames) < 2:
            raise click.UsageError("give the ROI file with --rois ROIS (as measure takes it)")
        roi_file, frames = frames[0], frames[1:]
        click.echo(
            f"DeprecationWarning: the ROI file as the first argument is deprecated; write "
            f"rois show FRAMES --rois {roi_file}",
            err=True,
        )
    roiset = read_rois(roi_file)
    image, dark_image, stack = _mean_frame(frames, dark)
    masks = class_masks(roiset, image.shape)
    offset = 0.0 if dark_image is None else dark_image
    stats = {}
    for name, mask in masks.items():
        values = (stack[:, mask] - (offset[mask] if dark_image is not None else 0.0)).ravel()
        stats[name] = (
            int(np.count_nonzero(mask)),
            float(values.mean()),
            float(values.std(ddof=1)) if values.size > 1 else 0.0,
        )
    labels = {n: f"{n}: {p} px, {m:.1f} ± {s:.1f} DN" for n, (p, m, s) in stats.items()}
    _write_picture(out, draw_regions(image - offset, masks, labels=labels))
    rows = [[n, str(p), f"{m:.2f}", f"{s:.2f}"] for n, (p, m, s) in stats.items()]
    mean = "μ [DN]" if dark_image is None else "μ − dark [DN]"  # as propose's column says
    click.echo(render_table(["class", "pixels", mean, "σ [DN]"], rows))
    click.echo(f"picture: {out}")


@rois.command(name="import")
@click.argument("annotations", type=PATH)
@click.option("--out", type=PATH, required=True, help="The ROI file to write (YAML).")
@click.option(
    "--names",
    help="Rename classes: LABEL=NAME pairs, comma-separated (e.g. 1=A,2=B, or "
    "person=A; a name given twice merges those labels).",
)
@click.option(
    "--drop",
    help="Labels to leave out, comma-separated (labelme's __ignore__ and _background_ "
    "are left out unless --names names them).",
)
@click.option("--image", help="COCO: the image whose annotations to take (file name or id).")
@click.option(
    "--size",
    "frame_size",
    type=SIZE,
    help="The frame size to record where the file has none (napari), as init's --size.",
)
@retired_option("--frame", "old_frame_size", type=SIZE, instead="write --size WxH")
@click.option("--force", is_flag=True, help="Overwrite OUT (and the masks it names) if it exists.")
def import_(annotations, out, names, drop, image, frame_size, old_frame_size, force):
    """Read another tool's ANNOTATIONS as an ROI file every command accepts.

    Integer label images (PNG, TIFF: napari, ilastik, QuPath; 0 is background), labelme
    JSON (polygons, rectangles, circles, masks), COCO JSON (polygons and RLE) and
    napari's shapes CSV. Shapes are clipped to the frame; pixels two classes share are
    left out of both; lines and points (no area) are skipped; each change is listed.
    Pixel masks are written exactly, one PNG per class beside OUT. The frame size is
    recorded from the file (or --size), so a frame of another size is refused. Nothing
    is written when the import is refused.
    """
    from inspect_validate.roi.annotations import import_annotations

    renames = {}
    for pair in (names or "").split(","):
        if not pair.strip():
            continue
        label, sep, name = pair.partition("=")
        if not sep or not label.strip() or not name.strip():
            raise click.BadParameter(
                f"{pair!r}: write LABEL=NAME, e.g. 1=A or person=A", param_hint="--names"
            )
        renames[label.strip()] = name.strip()
    dropped = [d.strip() for d in (drop or "").split(",") if d.strip()]
    frame_size = frame_size or old_frame_size
    written, notes = import_annotations(
        annotations,
        out,
        names=renames,
        image=image,
        drop=dropped,
        frame=frame_size,
        force=force,
        comment=f"Imported by inspect-validate rois import from {annotations}.",
    )
    for note in notes:
        click.echo(f"note: {note}", err=True)
    for cls in written.classes:
        click.echo(f"{cls.name}: {len(cls.shapes)} shape{'s' if len(cls.shapes) != 1 else ''}")
    if written.frame is None:
        click.echo(
            "warning: no frame size recorded (the file has none); give --size WxH so that a "
            "frame of another size is refused (and shapes past its border clipped)",
            err=True,
        )
    click.echo(f"ROI file: {out}")
