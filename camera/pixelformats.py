"""Monochrome pixel formats: unpacking raw camera buffers to uint8/uint16 arrays.

GenICam PFNC formats and the GigE Vision legacy packings, little-endian:

=============  ============  ==================================================
format         bits/pixel    layout
=============  ============  ==================================================
Mono8          8             one byte per pixel
Mono10/12/14/16 16           one little-endian uint16 per pixel, LSB-aligned
Mono10p        10            PFNC: a little-endian bit stream, 4 pixels in 5 bytes
Mono12p        12            PFNC: a little-endian bit stream, 2 pixels in 3 bytes
Mono10Packed   10 (in 12)    GigE Vision: 2 pixels in 3 bytes, 8 MSBs each in
                             bytes 0 and 2, the 2 LSBs in byte 1 (bits 0–1, 4–5)
Mono12Packed   12            GigE Vision: 2 pixels in 3 bytes, 8 MSBs each in
                             bytes 0 and 2, the 4 LSBs in byte 1 (bits 0–3, 4–7)
=============  ============  ==================================================

Buffers come from the camera's memory and may be re-queued: :func:`unpack`
always returns a new array that owns its data.
"""

from __future__ import annotations

import numpy as np

from inspect_validate.errors import DeviceError

__all__ = ["BIT_DEPTH", "MONO_FORMATS", "PACKED", "PFNC_CODES", "packed_size", "unpack"]

BIT_DEPTH = {
    "Mono8": 8,
    "Mono10": 10,
    "Mono12": 12,
    "Mono14": 14,
    "Mono16": 16,
    "Mono10p": 10,
    "Mono12p": 12,
    "Mono10Packed": 10,
    "Mono12Packed": 12,
}
MONO_FORMATS = tuple(BIT_DEPTH)
#: The 32-bit PFNC code a GigE Vision stream (GVSP) or a GenTL buffer carries → format name.
PFNC_CODES = {
    0x01080001: "Mono8",
    0x01100003: "Mono10",
    0x01100005: "Mono12",
    0x01100025: "Mono14",
    0x01100007: "Mono16",
    0x010A0046: "Mono10p",
    0x010C0047: "Mono12p",
    0x010C0004: "Mono10Packed",
    0x010C0006: "Mono12Packed",
}
_BITS_STORED = {"Mono8": 8, "Mono10p": 10, "Mono12p": 12, "Mono10Packed": 12, "Mono12Packed": 12}
#: Formats whose pixels share bytes (:func:`unpack` them).
PACKED = frozenset(f for f, bits in _BITS_STORED.items() if bits % 8)


def packed_size(pixel_format: str, n_pixels: int) -> int:
    """Bytes that ``n_pixels`` occupy in ``pixel_format``."""
    bits = _BITS_STORED.get(pixel_format, 16)
    return (n_pixels * bits + 7) // 8


def unpack(
    buffer: bytes | bytearray | memoryview | np.ndarray, pixel_format: str, width: int, height: int
) -> np.ndarray:
    """Unpack a raw buffer into a (height, width) uint8 (Mono8) or uint16 array.

    Raises
    ------
    DeviceError
        Unknown or colour pixel format, or a buffer shorter than the frame needs.
    """
    if pixel_format not in BIT_DEPTH:
        raise DeviceError(
            f"pixel format {pixel_format!r} is not a supported monochrome format "
            f"({', '.join(MONO_FORMATS)}); set the camera to one of them"
        )
    raw = np.frombuffer(buffer, dtype=np.uint8)
    n = width * height
    need = packed_size(pixel_format, n)
    if raw.size < need:
        raise DeviceError(
            f"{pixel_format} frame of {width}×{height} needs {need} bytes, the buffer has {raw.size}"
        )
    raw = raw[:need]
    if pixel_format == "Mono8":
        out = raw.copy()
    elif pixel_format in ("Mono10", "Mono12", "Mono14", "Mono16"):
        out = raw.view("<u2").astype(np.uint16)
    elif pixel_format == "Mono12p":
        out = _mono12p(raw, n)
    elif pixel_format == "Mono10p":
        out = _mono10p(raw, n)
    elif pixel_format == "Mono12Packed":
        out = _pairs(raw, n, shift=4, low_mask=0x0F)
    else:  # Mono10Packed
        out = _pairs(raw, n, shift=2, low_mask=0x03)
    return out.reshape(height, width)


def _groups(raw: np.ndarray, n: int, pixels: int, nbytes: int) -> np.ndarray:
    """Byte groups as uint16 columns, zero-padded to whole groups."""
    groups = -(-n // pixels)
    padded = np.zeros(groups * nbytes, dtype=np.uint8)
    padded[: raw.size] = raw
    return padded.reshape(groups, nbytes).astype(np.uint16)


def _mono12p(raw, n):
    b = _groups(raw, n, 2, 3)
    out = np.empty((b.shape[0], 2), np.uint16)
    out[:, 0] = b[:, 0] | ((b[:, 1] & 0x0F) << 8)
    out[:, 1] = (b[:, 1] >> 4) | (b[:, 2] << 4)
    return out.ravel()[:n]


def _mono10p(raw, n):
    b = _groups(raw, n, 4, 5)
    out = np.empty((b.shape[0], 4), np.uint16)
    out[:, 0] = b[:, 0] | ((b[:, 1] & 0x03) << 8)
    out[:, 1] = (b[:, 1] >> 2) | ((b[:, 2] & 0x0F) << 6)
    out[:, 2] = (b[:, 2] >> 4) | ((b[:, 3] & 0x3F) << 4)
    out[:, 3] = (b[:, 3] >> 6) | (b[:, 4] << 2)
    return out.ravel()[:n]


def _pairs(raw, n, *, shift, low_mask):
    """GigE Vision MonoXXPacked: MSBs in bytes 0 and 2, both pixels' LSBs in byte 1."""
    b = _groups(raw, n, 2, 3)
    out = np.empty((b.shape[0], 2), np.uint16)
    out[:, 0] = (b[:, 0] << shift) | (b[:, 1] & low_mask)
    out[:, 1] = (b[:, 2] << shift) | ((b[:, 1] >> 4) & low_mask)
    return out.ravel()[:n]
