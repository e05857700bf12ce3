"""Packed pixel formats, checked on hand-built byte buffers and an independent bit-stream packer."""

import numpy as np
import pytest

from inspect_validate.camera.pixelformats import packed_size, unpack
from inspect_validate.errors import DeviceError


def pack_lsb_stream(values, bits):
    """PFNC 'p' formats: concatenate each value's bits, least significant first."""
    stream = []
    for v in values:
        stream += [(int(v) >> i) & 1 for i in range(bits)]
    stream += [0] * (-len(stream) % 8)
    return bytes(
        sum(bit << i for i, bit in enumerate(stream[k : k + 8])) for k in range(0, len(stream), 8)
    )


def test_mono12p_by_hand():
    # Pixels 0xABC and 0x123: byte0 = 0xBC, byte1 = 0x3A (low nibble: 0xA, high: 0x3), byte2 = 0x12.
    assert unpack(bytes([0xBC, 0x3A, 0x12]), "Mono12p", 2, 1).tolist() == [[0xABC, 0x123]]


def test_mono10p_by_hand():
    values = [0x3FF, 0x001, 0x2AA, 0x155]
    assert unpack(pack_lsb_stream(values, 10), "Mono10p", 4, 1).tolist() == [values]
    # 0x3FF, 0, 0, 0 → bytes FF 03 00 00 00.
    assert unpack(bytes([0xFF, 0x03, 0, 0, 0]), "Mono10p", 4, 1).tolist() == [[0x3FF, 0, 0, 0]]


def test_gige_packed_by_hand():
    # Mono12Packed: p0 = 0xABC, p1 = 0x123 → byte0 = 0xAB, byte1 = (0x3 << 4) | 0xC, byte2 = 0x12.
    assert unpack(bytes([0xAB, 0x3C, 0x12]), "Mono12Packed", 2, 1).tolist() == [[0xABC, 0x123]]
    # Mono10Packed: p0 = 0x3FE, p1 = 0x001 → byte0 = 0xFF, byte1 = (0x1 << 4) | 0x2, byte2 = 0x00.
    assert unpack(bytes([0xFF, 0x12, 0x00]), "Mono10Packed", 2, 1).tolist() == [[0x3FE, 0x001]]


@pytest.mark.parametrize(("fmt", "bits"), [("Mono10p", 10), ("Mono12p", 12)])
@pytest.mark.parametrize("shape", [(7, 3), (64, 48), (5, 1)])
def test_pfnc_formats_against_the_bit_stream(fmt, bits, shape):
    rng = np.random.default_rng(1)
    w, h = shape
    values = rng.integers(0, 2**bits, w * h)
    buf = pack_lsb_stream(values, bits)
    assert len(buf) == packed_size(fmt, w * h)
    assert np.array_equal(unpack(buf, fmt, w, h), values.reshape(h, w))


def test_unpacked_formats_and_ownership():
    img = np.arange(12, dtype=np.uint16).reshape(3, 4) * 1000
    buf = bytearray(img.astype("<u2").tobytes())
    out = unpack(buf, "Mono16", 4, 3)
    assert np.array_equal(out, img) and out.dtype == np.uint16
    buf[0] = 99  # the camera re-queues its buffer: our frame must not change
    assert out[0, 0] == 0
    assert unpack(bytes(range(6)), "Mono8", 3, 2).dtype == np.uint8


def test_errors():
    with pytest.raises(DeviceError, match=r"RGB8.*not a supported monochrome"):
        unpack(b"\0" * 12, "RGB8", 2, 2)
    with pytest.raises(DeviceError, match="needs 3 bytes, the buffer has 2"):
        unpack(b"\0\0", "Mono12p", 2, 1)
