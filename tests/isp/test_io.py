"""isp.io: 16-bit PNG/TIFF written atomically, read back by independent decoders."""

from __future__ import annotations

import numpy as np
import pytest
import tifffile
from PIL import Image

from isp import PipelineError, write_image
from isp.io import to_uint16


@pytest.fixture
def image():
    return np.random.default_rng(0).uniform(size=(7, 9, 3))


def test_tiff_round_trip(tmp_path, image):
    p = write_image(tmp_path / "out.tif", image)
    back = tifffile.imread(p)
    assert back.dtype == np.uint16 and back.shape == (7, 9, 3)
    np.testing.assert_array_equal(back, np.round(image * 65535).astype(np.uint16))


def test_png_16bit_read_by_pillow(tmp_path, image):
    p = write_image(tmp_path / "out.png", image)
    im = Image.open(p)
    assert im.size == (9, 7)
    # Pillow decodes 48-bit RGB PNG to 8-bit RGB by keeping the high byte
    np.testing.assert_array_equal(np.asarray(im), (to_uint16(image) >> 8).astype(np.uint8))
    grey = write_image(tmp_path / "grey.png", image[..., 0])
    np.testing.assert_array_equal(np.asarray(Image.open(grey)), to_uint16(image[..., 0]))


def test_never_overwrites(tmp_path, image):
    src = tmp_path / "in.png"
    src.write_bytes(b"original")
    with pytest.raises(PipelineError, match="exists"):
        write_image(src, image)
    with pytest.raises(PipelineError, match="input file"):
        write_image(src, image, overwrite=True, protect=[src])
    assert src.read_bytes() == b"original"
    with pytest.raises(PipelineError, match="not written by isp"):  # overwrite replaces only our outputs
        write_image(src, image, overwrite=True)
    assert src.read_bytes() == b"original"
    ours = write_image(tmp_path / "out.png", image)
    write_image(ours, image, overwrite=True)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["in.png", "out.png"]  # no temporary left behind


def test_bad_inputs(tmp_path, image):
    with pytest.raises(PipelineError, match="format"):
        write_image(tmp_path / "a.jpg", image)
    with pytest.raises(PipelineError, match="NaN"):
        write_image(tmp_path / "a.png", image * np.nan)
    with pytest.raises(PipelineError, match="shape"):
        write_image(tmp_path / "a.png", np.zeros((2, 2, 2)))
    assert not any(tmp_path.iterdir())
