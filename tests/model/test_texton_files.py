"""Texton files: EXR and the reference viewer's .texton text format."""

from __future__ import annotations

import json
import pathlib

import numpy as np
import OpenEXR
import pytest

from warp_texton import Texton, TextonError, __version__, load_texton
from warp_texton.model.texton import is_texton_path
from warp_texton.core.checks import MAX_VALUE
from helpers import assert_nothing_written, parts, random_texton, raw_exr


def file_texton(rng, r=5, s=7, channels=3, order=1, **metadata) -> Texton:
    """A small texton with a random mean and ``metadata``, drawn from ``rng``."""
    return random_texton((r, s), channels, order, rng, gain=0.05, offset=0.0, mean=None, correlated=False,
                         metadata=metadata)


def texton_exr(path, coeffs, **attributes):
    coeffs = np.ascontiguousarray(coeffs, dtype=np.float32)
    channels = {"Y": np.ascontiguousarray(coeffs[:, :, 0])} if coeffs.shape[2] == 1 else {"RGB": coeffs}
    raw_exr(path, channels, **attributes)


def texton_text(order=1, mean="0.5 0.5 0.5", size="3 3", values=None, tail="Original image: x.png (8 x 8)"):
    """A .texton file as a string; ``values`` defaults to zeros for every texel."""
    w, h = (int(v) for v in size.split()) if len(size.split()) == 2 else (3, 3)
    if values is None:
        values = ["0 0 0"] * (w * h)
    return "\n".join(["TEXTON", "1", str(order), mean, size, *values, tail]) + "\n"


@pytest.fixture
def rng():
    return np.random.default_rng(2024)


# ------------------------------------------------------------------ constructor
class TestTextonConstructor:
    def test_valid_texton_is_float32_and_read_only(self, rng):
        t = Texton(rng.standard_normal((4, 6)), [0.5], 3)
        assert t.coeffs.shape == (4, 6, 1) and t.coeffs.dtype == np.float32
        assert t.mean.dtype == np.float32 and t.size == (4, 6) and t.channels == 1
        with pytest.raises(ValueError):
            t.coeffs[0, 0, 0] = 1.0

    @pytest.mark.parametrize("shape", [(4, 4, 2), (4, 4, 4), (0, 4, 1), (4,), (2, 2, 2, 1)])
    def test_bad_coefficient_shape(self, shape):
        with pytest.raises(TextonError, match=r"coefficients must have shape \(r, s, 1\) or \(r, s, 3\)"):
            Texton(np.zeros(shape), np.zeros(3), 1)

    @pytest.mark.parametrize("bad", [np.nan, np.inf])
    def test_non_finite_coefficients(self, bad):
        c = np.zeros((3, 3, 1))
        c[1, 2, 0] = bad
        with pytest.raises(TextonError, match="texton coefficients: contains 1 NaN or infinite values"):
            Texton(c, [0.0], 1)

    @pytest.mark.parametrize("mean, match", [([0.1, 0.2], "mean must be 3 finite values"),
                                             ([0.1], "mean must be 3 finite values"),
                                             ([0.1, 0.2, 0.3, 0.4], "mean must be 3 finite values"),
                                             ([0.1, np.nan, 0.3], "texton mean: contains 1 NaN or infinite"),
                                             ("x", "texton mean must be one number per channel, got text"),
                                             ([0.1, "0.2", 0.3], "texton mean must be one number per channel")])
    def test_bad_mean(self, mean, match):
        with pytest.raises(TextonError, match=match):
            Texton(np.zeros((3, 3, 3)), mean, 1)

    @pytest.mark.parametrize("order", [2, 4, -1, 7, True, 1.5])
    def test_bad_order(self, order):
        with pytest.raises(TextonError, match="order must be one of 0, 1, 3, 5"):
            Texton(np.zeros((3, 3, 1)), [0.0], order)


# ------------------------------------------------------------------ EXR textons
class TestExrTexton:
    @pytest.mark.parametrize("channels", [1, 3])
    @pytest.mark.parametrize("order", [0, 1, 3, 5])
    def test_round_trip_bit_exact(self, tmp_path, rng, channels, order):
        meta = {"source": "wood.png", "source_shape": [40, 50], "model_error": 0.4123456789, "seed": 7}
        t = file_texton(rng, channels=channels, order=order, **meta)
        path = tmp_path / "t.exr"
        t.save(path)
        back = load_texton(path)
        np.testing.assert_array_equal(back.coeffs, t.coeffs)
        assert back.coeffs.dtype == np.float32
        np.testing.assert_array_equal(back.mean, t.mean)
        assert back.order == order
        assert back.metadata == {**meta, "warp_texton": __version__}
        assert parts(tmp_path) == []

    def test_header_attributes(self, tmp_path, rng):
        t = file_texton(rng, order=3, source="a.png")
        path = tmp_path / "t.exr"
        t.save(path)
        header = OpenEXR.File(str(path)).header()
        assert header["texton_order"] == 3
        assert header["texton_version"] == 1
        np.testing.assert_array_equal(np.float32(header["texton_mean"]), t.mean)
        assert json.loads(header["texton_metadata"])["source"] == "a.png"

    def test_is_texton_path(self, tmp_path, rng):
        file_texton(rng).save(tmp_path / "t.exr")
        texton_exr(tmp_path / "img.exr", np.zeros((2, 2, 1)))
        assert is_texton_path(tmp_path / "t.exr")
        assert not is_texton_path(tmp_path / "img.exr")
        assert is_texton_path(tmp_path / "whatever.texton")
        assert not is_texton_path(tmp_path / "t.png")

    def test_plain_image_exr_is_not_a_texton(self, tmp_path):
        path = tmp_path / "image.exr"
        texton_exr(path, np.full((4, 4, 3), 0.5))
        with pytest.raises(TextonError, match="not a texton EXR .*texton_order"):
            load_texton(path)

    def test_mean_of_wrong_length(self, tmp_path):
        path = tmp_path / "t.exr"
        texton_exr(path, np.zeros((4, 4, 3)), texton_order=1, texton_mean=[0.1, 0.2])
        with pytest.raises(TextonError, match="2 mean values for 3 channels"):
            load_texton(path)

    def test_mean_not_numbers(self, tmp_path):
        path = tmp_path / "t.exr"
        texton_exr(path, np.zeros((4, 4, 1)), texton_order=1, texton_mean="abc")
        with pytest.raises(TextonError, match="texton_mean is not a list of numbers"):
            load_texton(path)

    def test_non_finite_mean(self, tmp_path):
        path = tmp_path / "t.exr"
        texton_exr(path, np.zeros((4, 4, 1)), texton_order=1, texton_mean=[float("nan")])
        with pytest.raises(TextonError, match="malformed texton file: texton mean: contains 1 NaN"):
            load_texton(path)

    @pytest.mark.parametrize("order", [7, 2, -1, 1.0, "1"])
    def test_bad_order_attribute(self, tmp_path, order):
        path = tmp_path / "t.exr"
        texton_exr(path, np.zeros((4, 4, 1)), texton_order=order, texton_mean=[0.5])
        with pytest.raises(TextonError, match="malformed texton EXR: order .* is not one of"):
            load_texton(path)

    @pytest.mark.parametrize("raw, match", [("{not json", "metadata is not JSON"),
                                            ("[1, 2]", "metadata is not a JSON object")])
    def test_bad_metadata(self, tmp_path, raw, match):
        path = tmp_path / "t.exr"
        texton_exr(path, np.zeros((4, 4, 1)), texton_order=1, texton_mean=[0.5], texton_metadata=raw)
        with pytest.raises(TextonError, match=match):
            load_texton(path)

    @pytest.mark.parametrize("raw, match", [
        ("[" * 100_000 + "]" * 100_000, "metadata nested deeper than 64 levels"),
        ('{"a": ' + "{" * 65 + "}" * 66, "metadata nested deeper than 64 levels"),
        ('{"a": "' + "x" * (1 << 20) + '"}', r"metadata of \d+ characters \(at most 1048576\)"),
    ], ids=["100k-deep", "66-deep", "1MiB"])
    def test_metadata_bounded(self, tmp_path, raw, match):
        # a deep nesting used to raise RecursionError from the JSON parser
        path = tmp_path / "deep.exr"
        texton_exr(path, np.zeros((4, 4, 1)), texton_order=1, texton_mean=[0.5], texton_metadata=raw)
        with pytest.raises(TextonError, match=f"deep.exr: malformed texton EXR: {match}"):
            load_texton(path)

    def test_metadata_depth_limit_and_brackets_in_strings(self, tmp_path):
        # 64 levels are read; brackets inside strings do not count
        raw = '{"a": ' + "[" * 63 + r'"[[{{ \" ]]"' + "]" * 63 + "}"
        path = tmp_path / "ok.exr"
        texton_exr(path, np.zeros((4, 4, 1)), texton_order=1, texton_mean=[0.5], texton_metadata=raw)
        assert load_texton(path).metadata == json.loads(raw)

    def test_nan_coefficients(self, tmp_path):
        c = np.zeros((4, 4, 1))
        c[0, 0] = np.nan
        path = tmp_path / "t.exr"
        texton_exr(path, c, texton_order=1, texton_mean=[0.5])
        with pytest.raises(TextonError, match="NaN or infinite"):
            load_texton(path)

    def test_garbage_exr(self, tmp_path):
        path = tmp_path / "t.exr"
        path.write_bytes(b"TEXTON\n1\n1\n")
        with pytest.raises(TextonError, match="not a readable EXR file"):
            load_texton(path)


class TestExtensionsAndPaths:
    def test_save_unsupported_extension(self, tmp_path, rng):
        path = tmp_path / "t.png"
        with pytest.raises(TextonError, match=r"unsupported texton extension '\.png'; use \.exr or \.texton"):
            file_texton(rng).save(path)
        assert_nothing_written(path)

    def test_load_unsupported_extension(self, tmp_path, rng):
        path = tmp_path / "t.png"
        path.write_bytes(b"\x89PNG\r\n")
        with pytest.raises(TextonError, match=r"unsupported texton extension '\.png'"):
            load_texton(path)

    def test_load_missing(self, tmp_path):
        with pytest.raises(TextonError, match="no such file"):
            load_texton(tmp_path / "nope.texton")

    @pytest.mark.parametrize("ext", [".exr", ".texton"])
    def test_save_into_missing_folder(self, tmp_path, rng, ext):
        path = tmp_path / "missing" / f"t{ext}"
        with pytest.raises(TextonError, match="does not exist"):
            file_texton(rng).save(path)
        assert not path.parent.exists()

    @pytest.mark.parametrize("ext", [".exr", ".texton"])
    def test_failed_save_keeps_old_file(self, tmp_path, rng, ext, monkeypatch):
        path = tmp_path / f"t{ext}"
        file_texton(rng).save(path)
        before = path.read_bytes()

        def half_write(name):
            with open(name, "wb") as f:
                f.write(b"TEXTON\n1\n")
            raise OSError(28, "No space left on device")

        if ext == ".exr":
            class BrokenFile:
                def __init__(self, header, channels):
                    pass

                def write(self, name):
                    half_write(name)

            monkeypatch.setattr(OpenEXR, "File", BrokenFile)
        else:
            monkeypatch.setattr(pathlib.Path, "write_text", lambda self, *a, **k: half_write(self))
        with pytest.raises(OSError, match="No space left"):
            file_texton(rng).save(path)
        assert path.read_bytes() == before
        assert parts(tmp_path) == []

    def test_unserialisable_metadata_writes_nothing(self, tmp_path, rng):
        path = tmp_path / "t.exr"
        with pytest.raises(TextonError, match=r"texton metadata\['thing'\]: object value .* cannot be saved"):
            file_texton(rng, thing=object()).save(path)
        assert_nothing_written(path)


# ------------------------------------------------------------------ .texton text
def parse_reference_layout(text):
    """Independent reader of the viewer's layout: returns (header, framed array, tail)."""
    lines = text.split("\n")
    assert lines[-1] == ""  # ends with a newline
    lines = lines[:-1]
    assert lines[0] == "TEXTON"
    assert lines[1] == "1"
    order = int(lines[2])
    mean = [float(v) for v in lines[3].split(" ")]
    w, h = (int(v) for v in lines[4].split(" "))
    body = lines[5: 5 + w * h]
    rows = np.array([[float(v) for v in line.split(" ")] for line in body])
    assert rows.shape == (w * h, 3)
    # bottom row first, each row left to right: flip to top-first [y, x, c]
    framed = rows.reshape(h, w, 3)[::-1]
    tail = lines[5 + w * h:]
    return order, mean, (w, h), framed, body, tail


class TestTextonText:
    @pytest.mark.parametrize("channels", [1, 3])
    def test_layout_matches_reference_viewer(self, tmp_path, rng, channels):
        r, s = 4, 6
        t = file_texton(rng, r=r, s=s, channels=channels, order=3,
                          source="wood.png", source_shape=[120, 90])
        path = tmp_path / "t.texton"
        t.save(path)
        text = path.read_bytes().decode("ascii")
        order, mean, (w, h), framed, body, tail = parse_reference_layout(text)
        assert order == 3
        assert (w, h) == (s + 2, r + 2)
        expected_mean = np.repeat(t.mean, 3) if channels == 1 else t.mean
        np.testing.assert_array_equal(np.float32(mean), expected_mean)
        # one-texel zero frame
        assert not framed[0].any() and not framed[-1].any()
        assert not framed[:, 0].any() and not framed[:, -1].any()
        coeffs = np.repeat(t.coeffs, 3, axis=2) if channels == 1 else t.coeffs
        np.testing.assert_array_equal(np.float32(framed[1:-1, 1:-1]), coeffs)
        # the first W lines and the last W lines are the (zero) bottom and top rows
        assert all(float(v) == 0.0 for line in body[:w] + body[-w:] for v in line.split())
        # line 5 + 1 + W + 1 (1-based) is the bottom-left coefficient [r-1, 0]
        line = text.split("\n")[5 + 1 + w + 1 - 1]
        np.testing.assert_array_equal(np.float32(line.split()), coeffs[r - 1, 0])
        # and the next one is its right neighbour
        line = text.split("\n")[5 + 1 + w + 1]
        np.testing.assert_array_equal(np.float32(line.split()), coeffs[r - 1, 1])
        assert tail == ["Original image: wood.png (90 x 120)"]

    @pytest.mark.parametrize("channels", [1, 3])
    @pytest.mark.parametrize("order", [0, 1, 3, 5])
    def test_round_trip_bit_exact(self, tmp_path, rng, channels, order):
        t = file_texton(rng, r=6, s=3, channels=channels, order=order,
                          source="stone.jpg", source_shape=[64, 80])
        path = tmp_path / "t.texton"
        t.save(path)
        back = load_texton(path)
        assert back.coeffs.shape == (6, 3, channels)
        np.testing.assert_array_equal(back.coeffs, t.coeffs)
        np.testing.assert_array_equal(back.mean, t.mean)
        assert back.order == order
        assert back.metadata["source"] == "stone.jpg"
        assert back.metadata["source_shape"] == [64, 80]
        assert parts(tmp_path) == []

    def test_extreme_float32_values_round_trip(self, tmp_path):
        # the extremes a texton accepts: ±MAX_VALUE (exact in float32) down to subnormals
        f = np.finfo(np.float32)
        special = [MAX_VALUE, -MAX_VALUE, f.tiny, f.smallest_subnormal, -f.smallest_subnormal,
                   np.float32(1) / 3, np.nextafter(np.float32(1), np.float32(2)), -0.0, 123456.789]
        c = np.array(special, dtype=np.float32).reshape(3, 3, 1)
        c = np.concatenate([c, -c[::-1], c * np.float32(1e-20)], axis=2)
        t = Texton(c, [MAX_VALUE, -1e-38, 0.1], 1)
        path = tmp_path / "x.texton"
        t.save(path)
        back = load_texton(path)
        np.testing.assert_array_equal(back.coeffs, t.coeffs)
        np.testing.assert_array_equal(back.mean, t.mean)

    def test_non_ascii_source_name(self, tmp_path, rng):
        t = file_texton(rng, source="größe.png", source_shape=[10, 12])
        path = tmp_path / "t.texton"
        t.save(path)
        back = load_texton(path)
        np.testing.assert_array_equal(back.coeffs, t.coeffs)
        assert back.metadata["source"].startswith("gr") and back.metadata["source"].endswith(".png")

    def test_texton_with_zero_border_keeps_its_size(self, tmp_path):
        c = np.zeros((5, 5, 1), np.float32)
        c[2, 2] = 1.0
        path = tmp_path / "t.texton"
        Texton(c, [0.0], 1).save(path)
        back = load_texton(path)
        np.testing.assert_array_equal(back.coeffs, c)

    @pytest.mark.parametrize("channels", [1, 3])
    @pytest.mark.parametrize("newline", ["\n", "\r\n"])
    def test_reads_reference_matlab_file(self, tmp_path, channels, newline):
        # What the authors' MATLAB writer produces: %e (6 digits), framed, bottom row first.
        r, s = 3, 4
        base = (np.arange(r * s, dtype=np.float64).reshape(r, s) + 1) * 0.125  # exact in %e
        if channels == 1:
            coeffs = np.repeat(base[:, :, None], 3, axis=2)
            mean = [0.5, 0.5, 0.5]
        else:
            coeffs = np.stack([base, -base, base * 1e-3], axis=2)
            mean = [0.25, 0.5, 0.75]
        framed = np.pad(coeffs, ((1, 1), (1, 1), (0, 0)))
        h, w = framed.shape[:2]
        lines = ["TEXTON", "1", "1", "%e %e %e" % tuple(mean), "%d %d" % (w, h)]
        for y in range(h - 1, -1, -1):  # OpenGL order: bottom row first
            for x in range(w):
                lines.append("%e %e %e" % tuple(framed[y, x]))
        lines.append("Original image: grass.png (128 x 128)")
        path = tmp_path / "ref.texton"
        path.write_bytes(newline.join(lines).encode("ascii") + newline.encode("ascii"))
        assert "1.250000e-01" in path.read_text()

        t = load_texton(path)
        assert t.size == (r, s)  # frame stripped
        assert t.channels == channels
        assert t.order == 1
        expected = base[:, :, None] if channels == 1 else coeffs
        np.testing.assert_array_equal(t.coeffs, expected.astype(np.float32))
        assert t.coeffs[0, 0, 0] == 0.125  # top-left is the first value of the top row
        assert t.coeffs[r - 1, 0, 0] == base[r - 1, 0]
        np.testing.assert_array_equal(t.mean, np.float32(mean[:channels]))
        assert t.metadata["source"] == "grass.png"
        assert t.metadata["source_shape"] == [128, 128]


class TestMalformedTextonText:
    @pytest.mark.parametrize(
        "content, match",
        [
            ("", "first line must be TEXTON"),
            (texton_text().replace("TEXTON", "TEXTUR", 1), "first line must be TEXTON"),
            (texton_text().replace("\n1\n", "\n2\n", 1), "version 2 is not supported"),
            (texton_text(order=2), "order 2 is not one of 0, 1, 3, 5"),
            (texton_text(mean="0.5 0.5"), "mean line must hold three finite values"),
            (texton_text(mean="0.5 nan 0.5"), "mean line must hold three finite values"),
            (texton_text(mean="0.5 abc 0.5"), "header must be TEXTON, version, order"),
            (texton_text(size="0 5", values=[]), r"size 0 x 5 is outside 1\.\.4096"),
            (texton_text(size="5000 5000", values=[]), r"size 5000 x 5000 is outside 1\.\.4096"),
            (texton_text(size="3"), "header must be"),
            (texton_text(size="3 3 3"), "header must be"),
            ("TEXTON\n1\n1\n", "header must be"),
            ("TEXTON\n1\n1\n0.5 0.5 0.5\n3 3\n" + "0 0 0\n" * 5, "expected 9 coefficient lines, found 5"),
            (texton_text(values=["0 0 0"] * 8 + ["0 zero 0"]), "something other than numbers"),
            (texton_text(values=["0 0 0"] * 8 + ["0 0"]), "expected 3 values on each of 9"),
            (texton_text(values=["0 0 0 0"] + ["0 0 0"] * 7 + ["0 0"]), "expected 3 values on each of 9"),
            (texton_text(values=["0 0 0"] * 4 + ["0 nan 0"] + ["0 0 0"] * 4), "coefficients must be finite"),
            (texton_text(values=["0 0 0"] * 4 + ["0 inf 0"] + ["0 0 0"] * 4), "coefficients must be finite"),
        ],
    )
    def test_malformed(self, tmp_path, content, match):
        path = tmp_path / "bad.texton"
        path.write_text(content, encoding="ascii")
        with pytest.raises(TextonError, match=rf"bad\.texton: malformed \.texton file: .*{match}"):
            load_texton(path)

    def test_truncated_real_file(self, tmp_path, rng):
        path = tmp_path / "cut.texton"
        file_texton(rng, r=4, s=4).save(path)
        lines = path.read_text().splitlines()
        path.write_text("\n".join(lines[:20]) + "\n")  # 36 coefficient lines expected
        with pytest.raises(TextonError, match="expected 36 coefficient lines, found 15"):
            load_texton(path)

    def test_non_ascii_bytes(self, tmp_path):
        path = tmp_path / "bad.texton"
        path.write_bytes(texton_text().encode("ascii").replace(b"Original", b"Orig\xc3\xafnal"))
        with pytest.raises(TextonError, match="not ASCII text"):
            load_texton(path)

    def test_binary_garbage(self, tmp_path):
        path = tmp_path / "bad.texton"
        path.write_bytes(bytes(range(256)))
        with pytest.raises(TextonError, match="malformed .texton file"):
            load_texton(path)

    def test_folder_named_texton(self, tmp_path):
        (tmp_path / "d.texton").mkdir()
        with pytest.raises(TextonError, match="no such file"):
            load_texton(tmp_path / "d.texton")
