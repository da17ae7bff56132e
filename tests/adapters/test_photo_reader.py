"""The dock and Processing read a photo with one decoder: the same pixels (EXIF orientation applied) and the same
refusal of a truncated JPEG (real files written here, the dock's QImage reader and Processing's array reader)."""

from __future__ import annotations

import numpy as np
import pytest

from monoplot_plugin.adapters.photo import PhotoError, qimage_to_array, read_photo
from monoplot_plugin.workflow.files import InputError
from monoplot_plugin.workflow.files import read_photo as read_photo_array


def write_rotated_jpeg(path, orientation=6):
    """An 80 x 40 picture (white band on its left quarter) with an EXIF orientation tag (an APP1 segment written
    by hand after the JPEG's start marker: one IFD entry, 0x0112 SHORT)."""
    import struct

    import cv2

    a = np.zeros((40, 80, 3), np.uint8)
    a[:, :20] = 255
    a[:, 20:40, 2] = 200
    ok, jpeg = cv2.imencode(".jpg", a, [cv2.IMWRITE_JPEG_QUALITY, 95])
    assert ok
    tiff = b"II*\x00" + struct.pack("<I", 8) + struct.pack("<H", 1) + struct.pack("<HHII", 0x0112, 3, 1, orientation)
    tiff += struct.pack("<I", 0)
    app1 = b"Exif\x00\x00" + tiff
    data = jpeg.tobytes()
    path.write_bytes(data[:2] + b"\xff\xe1" + struct.pack(">H", len(app1) + 2) + app1 + data[2:])


def test_dock_and_processing_see_the_same_upright_pixels(qgis_app, tmp_path):
    path = tmp_path / "turned.jpg"
    write_rotated_jpeg(path)
    dock = qimage_to_array(read_photo(str(path)))
    processing = read_photo_array(str(path))
    assert dock.shape == processing.shape == (80, 40, 3)
    assert np.array_equal(dock, processing)
    assert dock[:15, :, 0].mean() > 240  # the white band is at the top once the picture is upright


def test_a_truncated_jpeg_is_refused_by_the_dock_as_by_processing(qgis_app, tmp_path):
    path = tmp_path / "whole.jpg"
    write_rotated_jpeg(path, orientation=1)
    cut = tmp_path / "cut.jpg"
    cut.write_bytes(path.read_bytes()[: len(path.read_bytes()) * 2 // 3])
    with pytest.raises(PhotoError, match="truncated"):
        read_photo(str(cut))
    with pytest.raises(InputError, match="truncated"):
        read_photo_array(str(cut))
    with pytest.raises(PhotoError, match="no such file"):
        read_photo(str(tmp_path / "missing.jpg"))
