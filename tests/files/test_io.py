"""read_image / write_image: formats, scaling, alpha, atomic writes, errors."""

from __future__ import annotations

import contextlib
import os
import warnings

import imagecodecs
from helpers import assert_nothing_written, parts, raw_exr
from image_bombs import png_declaring, tiff_declaring
import numpy as np
import OpenEXR
import pytest
from PIL import Image
import tifffile

from warp_texton import TextonError, read_image, write_image
from warp_texton.core.limits import set_memory_budget

LOSSY_EXR = {
    OpenEXR.B44_COMPRESSION,
    OpenEXR.B44A_COMPRESSION,
    OpenEXR.DWAA_COMPRESSION,
    OpenEXR.DWAB_COMPRESSION,
    OpenEXR.PXR24_COMPRESSION,
}


@contextlib.contextmanager
def limits_set(budget: str):
    set_memory_budget(budget)
    try:
        yield
    finally:
        set_memory_budget(None)


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


# ------------------------------------------------------------------ EXR
class TestExr:
    @pytest.mark.parametrize("channels", [1, 3])
    def test_round_trip_is_exact(self, tmp_path, rng, channels):
        # negative values and values above 1 must survive: EXR is not clipped
        img = (rng.standard_normal((7, 11, channels)) * 3).astype(np.float32)
        path = tmp_path / "a.exr"
        write_image(path, img)
        back = read_image(path)
        assert back.dtype == np.float32
        assert back.shape == img.shape
        np.testing.assert_array_equal(back, img)
        assert parts(tmp_path) == []

    @pytest.mark.parametrize("channels, names", [(1, ["Y"]), (3, ["B", "G", "R"])])
    def test_channel_names_and_pixel_type(self, tmp_path, rng, channels, names):
        path = tmp_path / "a.exr"
        write_image(path, rng.random((4, 5, channels)).astype(np.float32))
        header = OpenEXR.File(str(path)).header()
        assert sorted(c.name for c in header["channels"]) == names
        # stored as float32, not half: compare with OpenEXR's own reading
        pix = OpenEXR.File(str(path)).channels()["Y" if channels == 1 else "RGB"].pixels
        assert pix.dtype == np.float32

    def test_compression_is_lossless(self, tmp_path, rng):
        path = tmp_path / "a.exr"
        write_image(path, rng.random((4, 4, 3)))
        compression = OpenEXR.File(str(path)).header()["compression"]
        assert compression not in LOSSY_EXR
        assert compression != OpenEXR.NO_COMPRESSION  # compressed, losslessly

    def test_float64_input_is_written_as_float32(self, tmp_path):
        img = np.array([[0.1, 1e10], [-2.5, 1.0 / 3.0]])
        path = tmp_path / "a.exr"
        write_image(path, img)
        np.testing.assert_array_equal(read_image(path)[:, :, 0], img.astype(np.float32))

    def test_separate_channels_from_another_writer(self, tmp_path, rng):
        # R, G, B written as three separate channels read back as one RGB image
        r, g, b = (np.ascontiguousarray(rng.random((3, 4), dtype=np.float32)) for _ in range(3))
        path = tmp_path / "sep.exr"
        raw_exr(path, {"R": r, "G": g, "B": b})
        back = read_image(path)
        np.testing.assert_array_equal(back, np.stack([r, g, b], axis=2))

    def test_half_float_exr(self, tmp_path):
        y = np.array([[0.5, -1.0], [2.0, 0.25]], dtype=np.float16)
        path = tmp_path / "half.exr"
        raw_exr(path, {"Y": y})
        back = read_image(path)
        assert back.dtype == np.float32
        np.testing.assert_array_equal(back[:, :, 0], y.astype(np.float32))

    def test_rgba_exr_drops_alpha(self, tmp_path, rng):
        rgba = rng.random((3, 4, 4), dtype=np.float32)
        path = tmp_path / "rgba.exr"
        raw_exr(path, {"RGBA": rgba})
        with pytest.warns(UserWarning, match="alpha"):
            back = read_image(path)
        np.testing.assert_array_equal(back, rgba[:, :, :3])

    @pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
    def test_non_finite_pixels_refused(self, tmp_path, bad):
        y = np.ones((4, 4), dtype=np.float32)
        y[2, 1] = bad
        path = tmp_path / "nan.exr"
        raw_exr(path, {"Y": y})
        with pytest.raises(TextonError, match="NaN or infinite"):
            read_image(path)

    def test_five_arbitrary_channels_refused(self, tmp_path, rng):
        path = tmp_path / "five.exr"
        raw_exr(path, {n: rng.random((4, 4), dtype=np.float32) for n in "abcde"})
        with pytest.raises(TextonError, match="not an image; expected Y, RGB or RGBA"):
            read_image(path)

    def test_garbage_exr_refused(self, tmp_path):
        path = tmp_path / "garbage.exr"
        path.write_bytes(b"\x76\x2f\x31\x01" + b"not really an exr file" * 10)
        with pytest.raises(TextonError, match="not a readable EXR file"):
            read_image(path)

    def test_png_named_exr_refused(self, tmp_path):
        path = tmp_path / "fake.exr"
        Image.fromarray(np.zeros((4, 4), np.uint8)).save(path, format="PNG")
        with pytest.raises(TextonError, match="not a readable EXR file"):
            read_image(path)


# ------------------------------------------------------------------ PNG / JPEG
class TestPng:
    def test_8bit_values_exact(self, tmp_path):
        k = np.arange(256, dtype=np.float64).reshape(16, 16)
        path = tmp_path / "k.png"
        write_image(path, (k / 255.0).astype(np.float32))
        with Image.open(path) as im:
            assert im.mode == "L"  # 8-bit grey
            np.testing.assert_array_equal(np.asarray(im), k.astype(np.uint8))
        back = read_image(path)
        assert back.shape == (16, 16, 1) and back.dtype == np.float32
        np.testing.assert_array_equal(back[:, :, 0], (k / 255.0).astype(np.float32))

    def test_8bit_rgb_round_trip(self, tmp_path, rng):
        k = rng.integers(0, 256, size=(5, 6, 3))
        path = tmp_path / "rgb.png"
        write_image(path, k / 255.0)
        with Image.open(path) as im:
            assert im.mode == "RGB"
        np.testing.assert_array_equal(read_image(path), (k / 255.0).astype(np.float32))

    def test_output_is_clipped_and_rounded(self, tmp_path):
        img = np.array([[-0.5, 0.25, 1.5, 2.0 / 255.0 + 0.4 / 255.0]], dtype=np.float32)
        path = tmp_path / "clip.png"
        write_image(path, img)
        with Image.open(path) as im:
            np.testing.assert_array_equal(np.asarray(im), [[0, 64, 255, 2]])
        np.testing.assert_array_equal(
            read_image(path)[:, :, 0], (np.array([[0, 64, 255, 2]]) / 255.0).astype(np.float32)
        )

    def test_16bit_png_scaled_by_65535(self, tmp_path):
        v = np.array([[0, 1, 1000, 32768], [40000, 65534, 65535, 257]], dtype=np.uint16)
        path = tmp_path / "deep.png"
        im = Image.fromarray(v)
        assert im.mode == "I;16"
        im.save(path)
        with Image.open(path) as reread:
            assert reread.mode.startswith("I")  # stored with 16 bits, not reduced to 8
        back = read_image(path)
        assert back.shape == (2, 4, 1)
        np.testing.assert_array_equal(back[:, :, 0], (v / 65535.0).astype(np.float32))

    def test_plain_2d_array_becomes_one_channel(self, tmp_path):
        path = tmp_path / "g.png"
        write_image(path, np.full((3, 5), 0.2))
        assert read_image(path).shape == (3, 5, 1)

    def test_rgba_png_drops_alpha_with_warning(self, tmp_path, rng):
        rgba = rng.integers(0, 256, size=(4, 5, 4), dtype=np.uint8)
        path = tmp_path / "rgba.png"
        Image.fromarray(rgba, mode="RGBA").save(path)
        with pytest.warns(UserWarning, match="alpha"):
            back = read_image(path)
        assert back.shape == (4, 5, 3)
        # colours are the stored ones, not premultiplied or composited
        np.testing.assert_array_equal(back, (rgba[:, :, :3] / 255.0).astype(np.float32))

    def test_la_png_drops_alpha_with_warning(self, tmp_path, rng):
        la = rng.integers(0, 256, size=(4, 5, 2), dtype=np.uint8)
        path = tmp_path / "la.png"
        Image.fromarray(la, mode="LA").save(path)
        with pytest.warns(UserWarning, match="alpha"):
            back = read_image(path)
        assert back.shape == (4, 5, 1)
        np.testing.assert_array_equal(back[:, :, 0], (la[:, :, 0] / 255.0).astype(np.float32))

    def test_rgba_array_written_without_alpha(self, tmp_path, rng):
        rgba = rng.random((3, 3, 4)).astype(np.float32)
        path = tmp_path / "w.exr"
        with pytest.warns(UserWarning, match="alpha"):
            write_image(path, rgba)
        np.testing.assert_array_equal(read_image(path), rgba[:, :, :3])

    def test_palette_png(self, tmp_path):
        palette = [10, 20, 30, 200, 100, 0, 255, 255, 255]
        idx = np.array([[0, 1, 2], [2, 1, 0]], dtype=np.uint8)
        im = Image.fromarray(idx, mode="P")
        im.putpalette(palette + [0] * (768 - len(palette)))
        path = tmp_path / "pal.png"
        im.save(path)
        back = read_image(path)
        assert back.shape == (2, 3, 3)
        colours = np.array(palette, dtype=np.float64).reshape(3, 3)
        np.testing.assert_array_equal(back, (colours[idx] / 255.0).astype(np.float32))

    def test_bilevel_png(self, tmp_path):
        bits = np.array([[True, False], [False, True]])
        path = tmp_path / "bits.png"
        Image.fromarray(bits).convert("1").save(path)
        np.testing.assert_array_equal(read_image(path)[:, :, 0], bits.astype(np.float32))

    @pytest.mark.parametrize("channels", [1, 3])
    def test_jpeg_readable(self, tmp_path, channels):
        y, x = np.mgrid[:16, :24]
        smooth = 0.2 + 0.6 * (x / 23.0)[:, :, None] * np.ones(channels)
        smooth = smooth * (0.5 + 0.5 * (y / 15.0))[:, :, None]
        path = tmp_path / "smooth.jpg"
        write_image(path, smooth)
        with Image.open(path) as im:
            assert im.format == "JPEG"
        back = read_image(path)
        assert back.shape == (16, 24, channels)
        assert np.abs(back - smooth).max() < 4 / 255

    def test_jpeg_written_elsewhere_readable(self, tmp_path):
        path = tmp_path / "other.jpeg"
        Image.new("RGB", (8, 6), (255, 0, 0)).save(path, quality=95)
        back = read_image(path)
        assert back.shape == (6, 8, 3)
        np.testing.assert_allclose(back.mean(axis=(0, 1)), [1.0, 0.0, 0.0], atol=3 / 255)


# ------------------------------------------------------------------ atomic writes
class TestAtomicWrite:
    def test_written_file_has_usual_permissions(self, tmp_path):
        path = tmp_path / "perm.png"
        write_image(path, np.zeros((2, 2)))
        mask = os.umask(0o022)
        os.umask(mask)
        # not the 0600 of the temporary file
        assert os.stat(path).st_mode & 0o777 == 0o666 & ~mask

    @pytest.mark.parametrize("ext", [".png", ".exr"])
    def test_nan_image_leaves_old_file_intact(self, tmp_path, ext):
        path = tmp_path / f"out{ext}"
        write_image(path, np.full((4, 4), 0.5))
        before = path.read_bytes()
        bad = np.full((4, 4), 0.5)
        bad[1, 1] = np.nan
        with pytest.raises(TextonError, match="NaN or infinite"):
            write_image(path, bad)
        assert path.read_bytes() == before
        assert parts(tmp_path) == []

    def test_unsupported_extension_leaves_old_file_intact(self, tmp_path):
        path = tmp_path / "old.bmp"
        path.write_bytes(b"previous content")
        with pytest.raises(TextonError, match=r"unsupported extension '\.bmp'"):
            write_image(path, np.zeros((2, 2)))
        assert path.read_bytes() == b"previous content"
        assert parts(tmp_path) == []

    def test_failing_png_writer_leaves_old_file_intact(self, tmp_path, monkeypatch):
        path = tmp_path / "out.png"
        write_image(path, np.full((4, 4), 0.25))
        before = path.read_bytes()

        def broken_save(self, fp, *args, **kwargs):
            with open(fp, "wb") as f:
                f.write(b"\x89PNG half written")
            raise OSError(28, "No space left on device")

        monkeypatch.setattr(Image.Image, "save", broken_save)
        with pytest.raises(OSError, match="No space left"):
            write_image(path, np.full((4, 4), 0.75))
        assert path.read_bytes() == before
        assert parts(tmp_path) == []

    def test_failing_exr_writer_leaves_no_file(self, tmp_path, monkeypatch):
        class BrokenFile:
            def __init__(self, header, channels):
                pass

            def write(self, name):
                with open(name, "wb") as f:
                    f.write(b"v/1\x01 partial")
                raise RuntimeError("disk went away")

        monkeypatch.setattr(OpenEXR, "File", BrokenFile)
        path = tmp_path / "out.exr"
        with pytest.raises(OSError, match="disk went away") as err:  # named after the output, one line on the CLI
            write_image(path, np.zeros((2, 2)))
        assert err.value.filename == str(path)
        assert_nothing_written(path)

    def test_missing_folder(self, tmp_path):
        path = tmp_path / "missing" / "out.png"
        with pytest.raises(TextonError, match="output folder .* does not exist"):
            write_image(path, np.zeros((2, 2)))
        assert not path.parent.exists()

    def test_folder_as_output(self, tmp_path):
        (tmp_path / "dir.png").mkdir()
        with pytest.raises(TextonError, match="is a folder"):
            write_image(tmp_path / "dir.png", np.zeros((2, 2)))
        assert parts(tmp_path) == []

    def test_no_extension(self, tmp_path):
        path = tmp_path / "noext"
        with pytest.raises(TextonError, match=r"unsupported extension '\(none\)'"):
            write_image(path, np.zeros((2, 2)))
        assert_nothing_written(path)

    def test_overwrite_replaces_content(self, tmp_path):
        path = tmp_path / "o.exr"
        write_image(path, np.zeros((2, 2)))
        write_image(path, np.ones((3, 2, 3)))
        np.testing.assert_array_equal(read_image(path), np.ones((3, 2, 3), np.float32))
        assert parts(tmp_path) == []


# ------------------------------------------------------------------ bad input
class TestReadErrors:
    def test_missing_file(self, tmp_path):
        with pytest.raises(TextonError, match="no such file"):
            read_image(tmp_path / "nope.png")

    def test_folder_instead_of_file(self, tmp_path):
        (tmp_path / "d.png").mkdir()
        with pytest.raises(TextonError, match="not a file"):
            read_image(tmp_path / "d.png")

    def test_text_named_png(self, tmp_path):
        path = tmp_path / "notes.png"
        path.write_text("this is not an image\n")
        with pytest.raises(TextonError, match="not an image that can be read"):
            read_image(path)

    def test_truncated_png(self, tmp_path, rng):
        path = tmp_path / "cut.png"
        Image.fromarray(rng.integers(0, 256, (32, 32), dtype=np.uint8)).save(path)
        path.write_bytes(path.read_bytes()[:60])
        with pytest.raises(TextonError, match="not an image that can be read"):
            read_image(path)

    def test_error_message_names_the_file(self, tmp_path):
        path = tmp_path / "named.png"
        path.write_text("x")
        with pytest.raises(TextonError, match="named.png"):
            read_image(path)


class TestWriteErrors:
    @pytest.mark.parametrize(
        "img, match",
        [
            (np.zeros((4, 4, 2)), "has 2 channels; expected 1 .*, 3 .* or 4"),
            (np.zeros((4, 4, 5)), "has 5 channels"),
            (np.zeros((0, 4)), "empty"),
            (np.zeros((4, 0, 3)), "empty"),
            (np.zeros(5), r"expected an image of shape \(H, W\) or \(H, W, C\)"),
            (np.zeros((2, 2, 2, 1)), "expected an image of shape"),
            (np.array([["a", "b"]]), "expected a numeric image array"),
            (np.zeros((2, 2), complex), "complex"),
        ],
    )
    @pytest.mark.parametrize("ext", [".png", ".exr"])
    def test_bad_arrays(self, tmp_path, img, match, ext):
        path = tmp_path / f"bad{ext}"
        with pytest.raises(TextonError, match=match):
            write_image(path, img)
        assert_nothing_written(path)

    def test_infinite_pixels(self, tmp_path):
        path = tmp_path / "inf.exr"
        with pytest.raises(TextonError, match="1 NaN or infinite"):
            write_image(path, np.array([[0.0, np.inf]]))
        assert_nothing_written(path)


# ------------------------------------------------------------------ output formats
class TestOutputFormats:
    @pytest.mark.parametrize("channels", [1, 3])
    def test_half_exr(self, tmp_path, rng, channels):
        img = (rng.standard_normal((6, 9, channels)) * 3).astype(np.float32)
        img[0, 0, 0] = 1e6  # beyond the half range: clipped to its largest finite value
        path = tmp_path / "h.exr"
        with pytest.warns(UserWarning, match="1 of 54 pixels .* clipped for float16"):
            assert write_image(path, img, dtype="float16") == 1
        f = OpenEXR.File(str(path))
        pix = f.channels()["Y" if channels == 1 else "RGB"].pixels
        assert pix.dtype == np.float16
        want = np.clip(img, -65504, 65504).astype(np.float16).astype(np.float32)
        np.testing.assert_array_equal(read_image(path), want)

    @pytest.mark.parametrize("name", ["zip", "zips", "piz", "rle", "none", "b44", "dwaa"])
    def test_exr_compression(self, tmp_path, rng, name):
        img = rng.random((16, 16, 3)).astype(np.float32)
        path = tmp_path / "c.exr"
        write_image(path, img, compression=name)
        want = OpenEXR.NO_COMPRESSION if name == "none" else getattr(OpenEXR, f"{name.upper()}_COMPRESSION")
        assert OpenEXR.File(str(path)).header()["compression"] == want
        if want not in LOSSY_EXR:
            np.testing.assert_array_equal(read_image(path), img)

    @pytest.mark.parametrize("channels", [1, 3])
    def test_16bit_png(self, tmp_path, channels):
        k = np.random.default_rng(channels).integers(0, 65536, (16, 15, channels))
        k[0, :2] = [0], [65535]  # both ends of the range
        img = k / 65535.0
        path = tmp_path / "d.png"
        assert write_image(path, img, dtype="uint16") == 0
        with open(path, "rb") as f:
            head = f.read(26)
        assert head[24] == 16 and head[25] == (0 if channels == 1 else 2)  # bit depth, colour type
        np.testing.assert_array_equal(read_image(path), img.astype(np.float32))

    @pytest.mark.parametrize("dtype", ["float32", "float16", "uint16", "uint8"])
    def test_tiff(self, tmp_path, rng, dtype):
        tifffile = pytest.importorskip("tifffile")
        img = rng.random((10, 12, 3)).astype(np.float32)
        path = tmp_path / "t.tif"
        write_image(path, img, dtype=dtype)
        assert tifffile.imread(str(path)).dtype == np.dtype(dtype)
        back = read_image(path)
        if dtype.startswith("uint"):
            top = np.iinfo(dtype).max
            want = (np.round(img * top) / top).astype(np.float32)
        else:
            want = img.astype(dtype).astype(np.float32)
        np.testing.assert_array_equal(back, want)

    def test_large_tiff_is_tiled(self, tmp_path, rng, monkeypatch):
        tifffile = pytest.importorskip("tifffile")
        import warp_texton.files.images

        monkeypatch.setattr(warp_texton.files.images, "TIFF_TILED_BYTES", 1000)
        img = rng.random((600, 700, 1)).astype(np.float32)
        path = tmp_path / "big.tiff"
        write_image(path, img, compression="zlib")
        with tifffile.TiffFile(str(path)) as tif:
            page = tif.pages[0]
            assert page.is_tiled and (page.tilelength, page.tilewidth) == (512, 512)
        np.testing.assert_array_equal(read_image(path), img)

    def test_clipped_pixels_are_counted_and_reported_once(self, tmp_path, recwarn):
        img = np.full((100, 100, 3), 0.5, np.float32)
        img[0, :50] = [-0.1, 0.5, 0.5]  # 50 pixels of 10000: below the 1 % threshold, counted, not reported
        assert write_image(tmp_path / "a.png", img) == 50
        assert len(recwarn) == 0
        img[1:3, :, 2] = 1.5  # 250 pixels: 2.5 %, reported once
        assert write_image(tmp_path / "b.png", img) == 250
        assert len(recwarn) == 1
        assert "250 of 10000 pixels (2.5 %) had values outside [0, 1], clipped for uint8" in str(recwarn[0].message)
        assert write_image(tmp_path / "c.exr", img) == 0  # float32 keeps them

    @pytest.mark.parametrize("path, kw, match", [
        ("a.jpg", dict(dtype="uint16"), r"\.jpg stores \(uint8\), not 'uint16'"),
        ("a.png", dict(dtype="float32"), r"\.png stores \(uint8, uint16\)"),
        ("a.exr", dict(dtype="uint8"), r"\.exr stores \(float32, float16"),
        ("a.png", dict(compression="zip"), "compression applies to .exr and .tif/.tiff outputs"),
        ("a.exr", dict(compression="jpeg"), "compression must be one of zip, zips, piz"),
        ("a.tif", dict(compression="jpeg"), "compression must be one of zlib, zstd, lzw, none for TIFF"),
        ("a.bmp", {}, r"unsupported extension '\.bmp'; use .png, .jpg, .jpeg, .exr, .tif or .tiff"),
    ])
    def test_bad_options(self, tmp_path, path, kw, match):
        with pytest.raises(TextonError, match=match):
            write_image(tmp_path / path, np.zeros((2, 2, 3)), **kw)
        assert_nothing_written(tmp_path / path)


# ------------------------------------------------ declared sizes, priced before decoding
class TestHeaderPricing:
    """A file whose header declares a huge image is refused from the header: the
    crafted files hold a 4x4 image, so a reader that decoded first would fail on the
    truncated data instead (or allocate the declared size)."""

    @pytest.mark.parametrize("mode, bits", [("L", 8), ("LA", 8), ("RGB", 8), ("RGBA", 8), ("P", 8),
                                            ("L", 16), ("LA", 16), ("RGB", 16), ("RGBA", 16)])
    def test_png_of_every_kind(self, tmp_path, mode, bits):
        path = png_declaring(tmp_path / "huge.png", 20000, 20000, mode=mode, bits=bits)
        with limits_set("256M"), pytest.raises(TextonError, match=r"huge\.png: a 20000x20000 image .*"
                                               r"over the memory budget of 256 MiB"):
            read_image(path)

    @pytest.mark.parametrize("samples, dtype", [(1, np.uint8), (2, np.uint16), (3, np.uint16), (3, np.float32)])
    def test_tiff(self, tmp_path, samples, dtype):
        path = tiff_declaring(tmp_path / "huge.tif", 30000, 30000, samples=samples, dtype=dtype)
        with limits_set("256M"), pytest.raises(TextonError, match=r"huge\.tif: a 30000x30000 image"):
            read_image(path)

    def test_jpeg(self, tmp_path):
        path = tmp_path / "huge.jpg"
        Image.new("RGB", (4, 4)).save(path)
        data = bytearray(path.read_bytes())
        sof = data.index(b"\xff\xc0")
        data[sof + 5:sof + 9] = (20000).to_bytes(2, "big") * 2
        path.write_bytes(bytes(data))
        with limits_set("256M"), pytest.raises(TextonError, match=r"huge\.jpg: a 20000x20000 image of 3 8-bit"):
            read_image(path)

    def test_the_estimate_grows_with_what_the_decoder_holds(self):
        from warp_texton.files.readers import Declared, decode_bytes

        grey8, rgb16 = Declared(100, 100, 1, 1, "pillow"), Declared(100, 100, 3, 2, "png16")
        assert decode_bytes(grey8) >= 100 * 100 * 5  # at least the float32 image and its mask
        assert decode_bytes(rgb16) >= 100 * 100 * (6 + 12)
        assert decode_bytes(Declared(100, 100, 3, 2, "tiff")) > decode_bytes(rgb16)  # strip buffers

    def test_an_image_the_budget_holds_is_read(self, tmp_path, rng):
        a = rng.integers(0, 65536, (30, 20, 3), dtype=np.uint16)
        (tmp_path / "ok.png").write_bytes(imagecodecs.png_encode(a))
        with limits_set("1M"):
            u = read_image(tmp_path / "ok.png")
        assert np.array_equal(u, (a / 65535.0).astype(np.float32))

    def test_pillows_bomb_limit_follows_the_budget(self, tmp_path):
        """A low Pillow limit neither warns nor refuses what the budget accepts; a
        format whose header Pillow reads (BMP) gives one TextonError past the budget."""
        Image.new("L", (100, 100), 7).save(tmp_path / "ok.bmp")
        for side in (30000, 15000):  # past twice Pillow's limit (its error), past it (its warning)
            Image.new("L", (4, 4)).save(tmp_path / f"huge{side}.bmp")
            data = bytearray((tmp_path / f"huge{side}.bmp").read_bytes())
            data[18:26] = side.to_bytes(4, "little") * 2
            (tmp_path / f"huge{side}.bmp").write_bytes(bytes(data))
        before = Image.MAX_IMAGE_PIXELS
        try:
            Image.MAX_IMAGE_PIXELS = 1000
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                assert read_image(tmp_path / "ok.bmp").shape == (100, 100, 1)
                for side in (30000, 15000):
                    with limits_set("1G"), pytest.raises(TextonError, match=f"huge{side}.bmp.*memory budget"):
                        read_image(tmp_path / f"huge{side}.bmp")
            # the reader's raise is scoped to its own reads: Pillow's limit is back after them
            assert Image.MAX_IMAGE_PIXELS == 1000
            Image.MAX_IMAGE_PIXELS = None  # unset by the user: stays unset
            read_image(tmp_path / "ok.bmp")
            assert Image.MAX_IMAGE_PIXELS is None
        finally:
            Image.MAX_IMAGE_PIXELS = before

    def test_pillows_limit_is_raised_only_while_reading(self, tmp_path, monkeypatch):
        """During a read the limit is the budget's largest image, in every thread's view (a
        module setting); after the last concurrent read it is Pillow's own again, unless
        someone else changed it meanwhile."""
        import threading

        import warp_texton.files.readers as R

        Image.new("L", (64, 64), 7).save(tmp_path / "a.bmp")
        before = Image.MAX_IMAGE_PIXELS
        seen, go = [], threading.Barrier(2)
        real = R._pil_pixels

        def slow(im, path):  # two reads overlap: each sees the raised limit
            seen.append(Image.MAX_IMAGE_PIXELS)
            go.wait(10)
            return real(im, path)

        monkeypatch.setattr(R, "_pil_pixels", slow)
        with limits_set("1G"):
            threads = [threading.Thread(target=read_image, args=(tmp_path / "a.bmp",)) for _ in range(2)]
            for t in threads:
                t.start()
            for t in threads:
                t.join(20)
        assert seen == [(1 << 30) // R.MIN_PIXEL_BYTES] * 2 and before < seen[0]
        assert Image.MAX_IMAGE_PIXELS == before
        monkeypatch.setattr(R, "_pil_pixels", lambda im, path: setattr(Image, "MAX_IMAGE_PIXELS", 5) or real(im, path))
        try:
            read_image(tmp_path / "a.bmp")
            assert Image.MAX_IMAGE_PIXELS == 5  # changed during the read: kept
        finally:
            Image.MAX_IMAGE_PIXELS = before

    def test_image_size_reads_the_header_only(self, tmp_path):
        from warp_texton.files.images import image_size

        assert image_size(png_declaring(tmp_path / "a.png", 20000, 10000, mode="RGBA")) == (10000, 20000, 3)
        assert image_size(tiff_declaring(tmp_path / "b.tif", 300, 200, samples=2)) == (200, 300, 1)


# ------------------------------------------------ TIFF layouts: read as declared or refused
class TestTiffLayouts:
    @pytest.mark.parametrize("rows", [1, 2, 3, 4])
    def test_grey_and_alpha_with_few_rows(self, tmp_path, rng, rows):
        a = rng.integers(0, 65536, (rows, 40, 2), dtype=np.uint16)
        tifffile.imwrite(tmp_path / "ga.tif", a, photometric="minisblack", extrasamples=["unassalpha"])
        with pytest.warns(UserWarning, match="alpha"):
            u = read_image(tmp_path / "ga.tif")
        assert np.array_equal(u, (a[:, :, :1] / 65535.0).astype(np.float32))

    @pytest.mark.parametrize("width", [1, 2, 5])
    def test_planar_rgb(self, tmp_path, rng, width):
        a = rng.integers(0, 256, (3, 40, width), dtype=np.uint8)
        tifffile.imwrite(tmp_path / "p.tif", a, photometric="rgb", planarconfig="separate")
        u = read_image(tmp_path / "p.tif")
        assert np.array_equal(u, (np.moveaxis(a, 0, -1) / 255.0).astype(np.float32))

    @pytest.mark.parametrize("shape, match", [((3, 20, 20), "3 pages"), ((4, 20, 20, 3), "4 pages"),
                                              ((2, 3, 10, 10), "6 pages")])
    def test_stacks_are_refused(self, tmp_path, rng, shape, match):
        a = rng.integers(0, 256, shape, dtype=np.uint8)
        tifffile.imwrite(tmp_path / "s.tif", a, photometric="rgb" if shape[-1] == 3 else "minisblack")
        with pytest.raises(TextonError, match=rf"s\.tif: a TIFF with {match}"):
            read_image(tmp_path / "s.tif")

    @pytest.mark.parametrize("photometric, samples", [("separated", 4), ("miniswhite", 1), ("minisblack", 3)])
    def test_undeclared_colour_layouts_are_refused(self, tmp_path, rng, photometric, samples):
        a = rng.integers(0, 256, (8, 8, samples) if samples > 1 else (8, 8), dtype=np.uint8)
        kw = {"planarconfig": "contig"} if samples > 1 else {}
        tifffile.imwrite(tmp_path / "c.tif", a, photometric=photometric, **kw)
        with pytest.raises(TextonError, match=rf"a {photometric} TIFF with {samples} samples"):
            read_image(tmp_path / "c.tif")

    def test_palette_tiff_is_read_through_its_colour_map(self, tmp_path):
        cmap = np.zeros((3, 256), np.uint16)
        cmap[0, 1] = 65535  # index 1 is red
        tifffile.imwrite(tmp_path / "pal.tif", np.array([[0, 1]], np.uint8), photometric="palette", colormap=cmap)
        assert read_image(tmp_path / "pal.tif").tolist() == [[[0, 0, 0], [1, 0, 0]]]

    def test_stack_on_the_command_line(self, tmp_path, capsys):
        from warp_texton.cli.parser import main

        tifffile.imwrite(tmp_path / "stack3.tif", np.zeros((3, 16, 16), np.uint8), photometric="minisblack")
        assert main(["analyze", str(tmp_path / "stack3.tif"), "-o", str(tmp_path / "t.exr")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "3 pages" in err
        assert not (tmp_path / "t.exr").exists()


class TestSixteenBitPng:
    @pytest.mark.parametrize("samples", [2, 3, 4])
    def test_all_sixteen_bits_are_read(self, tmp_path, rng, samples):
        a = rng.integers(0, 65536, (9, 7, samples), dtype=np.uint16)
        (tmp_path / "a.png").write_bytes(imagecodecs.png_encode(a))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the alpha warning
            u = read_image(tmp_path / "a.png")
        keep = 1 if samples == 2 else 3
        assert np.array_equal(u, (a[:, :, :keep] / 65535.0).astype(np.float32))


class TestWriteArguments:
    @pytest.mark.parametrize("dtype", [0, 1.5, [1], "int7", object, np.dtype("complex64")])
    def test_bad_dtype(self, tmp_path, dtype):
        with pytest.raises(TextonError, match=r"\.png stores \(uint8, uint16\)") as exc:
            write_image(tmp_path / "a.png", np.zeros((2, 2)), dtype=dtype)
        assert exc.value.param == "dtype"
        assert not list(tmp_path.iterdir())

    @pytest.mark.parametrize("compression", [np.array([4, 4]), 4, ["zip"], b"zip"])
    def test_bad_compression(self, tmp_path, compression):
        with pytest.raises(TextonError, match="compression must be a name") as exc:
            write_image(tmp_path / "a.exr", np.zeros((2, 2)), compression=compression)
        assert exc.value.param == "compression"

    def test_numpy_types_still_name_a_dtype(self, tmp_path):
        write_image(tmp_path / "a.png", np.zeros((2, 2)), dtype=np.uint16)
        assert Image.open(tmp_path / "a.png").mode.startswith("I;16")

    def test_huge_values_give_no_numpy_warning(self, tmp_path):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with pytest.raises(TextonError, match="within"):
                write_image(tmp_path / "a.exr", np.full((2, 2), 1e300))


class TestInterruptibleWrite:
    def test_a_failing_threaded_write_is_reported_and_leaves_nothing(self, tmp_path, monkeypatch):
        from warp_texton.files import images as io

        monkeypatch.setattr(io, "THREADED_WRITE_BYTES", 0)
        write_image(tmp_path / "a.exr", np.ones((8, 8, 3)))
        assert read_image(tmp_path / "a.exr").shape == (8, 8, 3)

        def fail():
            raise RuntimeError("No space left on device")

        with pytest.raises(RuntimeError, match="No space"):
            io._interruptible(fail, str(tmp_path / "x"), 1)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["a.exr"]
