"""Image decoding and encoding shared by every stage.

All decoders return linear-light RGB ``float32`` arrays of shape (H, W, 3)
plus the per-pixel "clipped" mask of the encoded values; all problems surface
as :class:`ImageRejected`, whose message is one line naming the file.
"""
from __future__ import annotations

import contextlib
import errno
import os
import stat
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import drjit as dr
import numpy as np
from PIL import Image, ImageOps

from clothscope.core.atomic import write_with

EXR_SUFFIXES = {".exr"}
#: Pillow tile raw modes of 16-bit colour PNGs, which Pillow itself truncates to 8 bit.
_PNG16_RAWMODES = {"RGB;16B", "RGBA;16B", "LA;16B"}


class ImageRejected(ValueError):
    """An input image that cannot be used; ``str(err)`` is a one-line reason."""


@dataclass
class DecodedImage:
    """Linear RGB pixels and what was learned while decoding them."""

    rgb: np.ndarray  # (H, W, 3) float32, linear light
    clipped: np.ndarray  # (H, W) bool, any channel at or above the clip threshold
    notes: list[str] = field(default_factory=list)
    source_format: str = ""
    bit_depth: int = 8


def srgb_to_linear(x: np.ndarray) -> np.ndarray:
    """Inverse sRGB transfer function (IEC 61966-2-1) on values in [0, 1]."""
    x = np.clip(np.asarray(x, dtype=np.float32), 0.0, 1.0)
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4).astype(np.float32)


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    """sRGB transfer function on linear values, clipped to [0, 1]."""
    x = np.clip(np.asarray(x, dtype=np.float32), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055).astype(np.float32)


def _reject(path: Path, reason: str) -> ImageRejected:
    return ImageRejected(f"{path}: {reason}")


def _check_size(path: Path, width: int, height: int, min_px: int, max_megapixels: float) -> None:
    if min(width, height) < min_px:
        raise _reject(path, f"image is {width}x{height} px, smaller than the minimum side of {min_px} px")
    megapixels = width * height / 1e6
    if megapixels > max_megapixels:
        raise _reject(
            path,
            f"image is {width}x{height} px ({megapixels:.1f} MP), above the limit of {max_megapixels:g} MP "
            "(prepare.max_megapixels); downscale it first",
        )


def _normalised_channels(img: Image.Image) -> tuple[np.ndarray, int, list[str]]:
    """Pillow image -> (H, W, C) encoded values (uint8 or uint16 codes for 8- and 16-bit images, else float32 in
    [0, 1]), bit depth, notes."""
    notes: list[str] = []
    mode = img.mode
    if mode in ("I;16", "I;16B", "I;16L", "I;16N"):
        return np.asarray(img).astype(np.uint16)[..., None], 16, notes  # codes, decoded through a table like 8-bit ones
    if mode == "I":
        arr = np.asarray(img, dtype=np.float64)
        scale = 65535.0 if arr.max(initial=0) > 255 else 255.0
        return (arr / scale).astype(np.float32)[..., None], 16 if scale > 255 else 8, notes
    if mode == "F":
        notes.append("float grayscale treated as encoded values in [0, 1]")
        return np.asarray(img, dtype=np.float32)[..., None], 32, notes
    if mode == "CMYK":
        notes.append("CMYK converted to RGB without an ICC profile")
        img = img.convert("RGB")
    elif mode in ("RGBA", "LA", "PA") or (mode == "P" and "transparency" in img.info):
        notes.append("alpha channel ignored")
        img = img.convert("RGB")
    elif mode not in ("RGB", "L"):
        img = img.convert("RGB")
    codes = np.asarray(img, dtype=np.uint8)  # kept as 8-bit codes: decoded through a table, no float temporaries
    return (codes[..., None] if codes.ndim == 2 else codes), 8, notes


def _decode_png16(path: Path) -> np.ndarray:
    """16-bit colour PNG codes (uint16, alpha dropped) via Mitsuba's Bitmap (Pillow truncates them)."""
    mi = _mitsuba_scalar()
    with _thread_pool_of_two():
        codes = np.array(mi.Bitmap(str(path)), dtype=np.uint16)
    return codes[..., :1] if codes.shape[2] == 2 else codes[..., :3]  # grey + alpha: the grey


def _mitsuba_scalar():
    import mitsuba as mi  # about 1 s to import: loaded on the first EXR read or write

    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    return mi


@contextlib.contextmanager
def _thread_pool_of_two() -> Iterator[None]:
    """Run OpenEXR I/O with at least 2 Dr.Jit threads.

    Mitsuba 3.9.1's OpenEXR reader and writer wait on the Dr.Jit thread pool: once
    a job has set 1 thread (``fit.threads: 1``), the next EXR read or write in
    that process hangs forever.
    """
    threads = dr.thread_count()
    if threads < 2:
        dr.set_thread_count(2)
    try:
        yield
    finally:
        if threads < 2:
            dr.set_thread_count(threads)


def _to_rgb(channels: np.ndarray) -> np.ndarray:
    if channels.shape[2] == 1:
        return np.repeat(channels, 3, axis=2)
    return channels[..., :3]


@contextlib.contextmanager
def _without_pillow_size_guard() -> Iterator[None]:
    """Open images with Pillow's decompression-bomb guard off: our own size limit (checked from the header,
    before any pixel is decoded) replaces it, so the message names the setting."""
    pillow_limit, Image.MAX_IMAGE_PIXELS = Image.MAX_IMAGE_PIXELS, None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            yield
    finally:
        Image.MAX_IMAGE_PIXELS = pillow_limit


def _loaded(path: Path, min_px: int, max_megapixels: float) -> tuple[Image.Image, str, str]:
    """The image at ``path`` opened, its size checked and its pixels loaded, with its raw mode and format; the file is
    closed again when any of it fails."""
    with _without_pillow_size_guard():
        img = Image.open(path)
        try:
            _check_size(path, img.width, img.height, min_px, max_megapixels)
            rawmode = img.tile[0].args if img.tile and isinstance(img.tile[0].args, str) else ""
            fmt = img.format or "unknown"
            img.load()
        except BaseException:
            img.close()
            raise
    return img, rawmode, fmt


def decode_raster(path: Path, min_px: int, max_megapixels: float, clip_threshold: float) -> DecodedImage:
    """Decode PNG, JPEG, TIFF, BMP, WebP (or anything Pillow reads) with EXIF orientation applied."""
    try:
        img, rawmode, fmt = _loaded(path, min_px, max_megapixels)
    except ImageRejected:
        raise
    except Image.UnidentifiedImageError:
        if path.suffix.lower() in (".tif", ".tiff"):
            raise _reject(path, "a TIFF layout this reader cannot decode (e.g. 32-bit float colour) or a corrupt TIFF; "
                                "save it as 16-bit PNG or OpenEXR") from None
        raise _reject(path, "not a readable image (unknown or corrupt format)") from None
    except (OSError, SyntaxError, ValueError) as err:
        raise _reject(path, f"cannot decode {path.suffix or 'file'}: {err}") from None
    with img:
        orientation = img.getexif().get(0x0112, 1)
        if fmt == "PNG" and rawmode in _PNG16_RAWMODES:
            encoded, depth, notes = _decode_png16(path), 16, []
            if orientation not in (1, None):
                notes.append("EXIF orientation of 16-bit colour PNG ignored")
        else:
            encoded, depth, notes = _normalised_channels(ImageOps.exif_transpose(img))
            if orientation not in (1, None):
                notes.append(f"EXIF orientation {orientation} applied")
    encoded = _to_rgb(encoded)
    if fmt == "TIFF" and depth == 8 and ";16" in rawmode:
        notes.append("16-bit colour TIFF decoded at 8-bit precision")
    if encoded.dtype in (np.uint8, np.uint16):
        rgb, clipped = _decode_codes(encoded, clip_threshold)
        return DecodedImage(rgb=rgb, clipped=clipped, notes=notes, source_format=fmt, bit_depth=depth)
    bad = int(np.count_nonzero(~np.isfinite(encoded).all(axis=2)))
    if bad:
        raise _reject(path, f"{bad} pixel(s) hold NaN or infinite values")
    clipped = np.any(encoded >= clip_threshold, axis=2)
    rgb = encoded if depth == 32 else srgb_to_linear(encoded)
    return DecodedImage(rgb=rgb, clipped=clipped, notes=notes, source_format=fmt, bit_depth=depth)


def _decode_codes(codes: np.ndarray, clip_threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """Linear RGB (float32) and clipped mask of (H, W, 3) 8- or 16-bit sRGB codes, through 256- or 65536-entry tables.

    Same values as :func:`srgb_to_linear` on ``codes / 255`` (``/ 65535``), with
    12 bytes per pixel of output and no float temporaries.
    """
    top = np.iinfo(codes.dtype).max
    encoded = np.arange(top + 1, dtype=np.float32) / float(top)
    clipped = np.any((encoded >= clip_threshold)[codes], axis=2)
    return srgb_to_linear(encoded)[codes], clipped


def decode_exr(path: Path, min_px: int, max_megapixels: float) -> DecodedImage:
    """Decode an OpenEXR file (already linear) through Mitsuba's Bitmap."""
    mi = _mitsuba_scalar()
    try:
        with _thread_pool_of_two():
            bitmap = mi.Bitmap(str(path))
            channels = np.array(bitmap, dtype=np.float32)
    except RuntimeError as err:
        raise _reject(path, f"cannot decode OpenEXR: {str(err).splitlines()[0]}") from None
    width, height = bitmap.size()
    _check_size(path, width, height, min_px, max_megapixels)
    if channels.ndim == 2:
        channels = channels[..., None]
    rgb = _to_rgb(channels)
    bad = int(np.count_nonzero(~np.isfinite(rgb)))
    if bad:
        raise _reject(path, f"OpenEXR holds {bad} non-finite values")
    if np.any(rgb < 0):
        rgb = np.maximum(rgb, 0.0)
    return DecodedImage(rgb=rgb, clipped=np.zeros(rgb.shape[:2], bool), source_format="EXR", bit_depth=32)


def read_exr(path: str | os.PathLike[str]) -> np.ndarray:
    """Read an OpenEXR written by :func:`write_exr` back as raw float32 (H, W, C), signs kept."""
    mi = _mitsuba_scalar()
    with _thread_pool_of_two():
        data = np.array(mi.Bitmap(str(path)), dtype=np.float32)
    return data[..., None] if data.ndim == 2 else data


def file_problem(path: str | os.PathLike[str]) -> str | None:
    """Why ``path`` cannot be read as an image file (missing, a directory, a broken or looping symlink,
    unreadable, empty), or None when it is a readable regular file."""
    path = Path(path)
    try:
        info = path.stat()
    except OSError as err:
        if path.is_symlink():
            return "symlink loop" if err.errno == errno.ELOOP else f"broken symlink (its target {os.readlink(path)} does not exist)"
        return "file does not exist" if err.errno == errno.ENOENT else f"cannot be read ({err.strerror})"
    if stat.S_ISDIR(info.st_mode):
        return "is a directory, not an image file"
    if not stat.S_ISREG(info.st_mode):
        return "is not a regular file"
    if not os.access(path, os.R_OK):
        return "cannot be read (permission denied)"
    if info.st_size == 0:
        return "file is empty (0 bytes)"
    return None


def _exr_header_size(path: Path) -> tuple[int, int] | None:
    """Width and height from an OpenEXR file's ``dataWindow`` attribute (a scan of its header only)."""
    with open(path, "rb") as f:
        header = f.read(65536)
    if header[:4] != b"\x76\x2f\x31\x01":
        return None
    at = 8
    while at < len(header) and header[at] != 0:
        name_end = header.index(b"\0", at)
        type_end = header.index(b"\0", name_end + 1)
        size = int.from_bytes(header[type_end + 1:type_end + 5], "little", signed=True)
        value = header[type_end + 5:type_end + 5 + size]
        if header[at:name_end] == b"dataWindow" and len(value) == 16:
            x0, y0, x1, y1 = (int.from_bytes(value[i:i + 4], "little", signed=True) for i in range(0, 16, 4))
            return x1 - x0 + 1, y1 - y0 + 1
        at = type_end + 5 + size
    return None


def header_size(path: str | os.PathLike[str]) -> tuple[int, int] | None:
    """An image file's width and height from its header, no pixel decoded; None when it cannot be read."""
    path = Path(path)
    try:
        if path.suffix.lower() in EXR_SUFFIXES:
            return _exr_header_size(path)
        with _without_pillow_size_guard(), Image.open(path) as img:
            return img.width, img.height
    except (OSError, ValueError, SyntaxError, Image.UnidentifiedImageError):
        return None


def decode_image(
    path: str | os.PathLike[str], min_px: int, max_megapixels: float, clip_threshold: float
) -> DecodedImage:
    """Decode any supported image file to linear RGB.

    Raises
    ------
    ImageRejected
        With a one-line reason naming ``path`` when the file is missing, empty,
        unreadable, too small or too large.
    """
    path = Path(path)
    problem = file_problem(path)
    if problem:
        raise _reject(path, problem)
    if path.suffix.lower() in EXR_SUFFIXES:
        return decode_exr(path, min_px, max_megapixels)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        decoded = decode_raster(path, min_px, max_megapixels, clip_threshold)
    decoded.notes.extend(decoder_notes(caught))
    return decoded


def decoder_notes(caught: list[warnings.WarningMessage]) -> list[str]:
    """One note per distinct warning the decoder raised (a damaged TIFF tag, a truncated chunk), for the status file
    instead of a Python warning naming the decoder's source on stderr."""
    return list(dict.fromkeys(f"decoder warning: {w.message}" for w in caught))


def write_png(target: str | os.PathLike[str], encoded: np.ndarray, bits: int = 8) -> None:
    """Atomically write encoded values in [0, 1] as an 8-bit (RGB or gray) or 16-bit gray PNG."""
    encoded = np.clip(np.nan_to_num(np.asarray(encoded, dtype=np.float64)), 0.0, 1.0)
    if bits == 16:
        if encoded.ndim != 2:
            raise ValueError("16-bit PNGs are written for single-channel data only")
        image = Image.fromarray(np.round(encoded * 65535).astype(np.uint16))
    else:
        image = Image.fromarray(np.round(encoded * 255).astype(np.uint8))
    write_with(target, lambda tmp: image.save(tmp, format="PNG"))


def read_png(path: str | os.PathLike[str]) -> np.ndarray:
    """Read a PNG written by :func:`write_png` back to values in [0, 1]."""
    with Image.open(path) as img:
        arr = np.asarray(img)
    scale = 65535.0 if arr.dtype == np.uint16 else 255.0
    return arr.astype(np.float32) / scale


def write_exr(target: str | os.PathLike[str], data: np.ndarray) -> None:
    """Atomically write float data (H, W[, C]) as a float32 OpenEXR through Mitsuba."""
    mi = _mitsuba_scalar()
    data = np.ascontiguousarray(data, dtype=np.float32)
    if not np.all(np.isfinite(data)):
        raise ValueError(f"refusing to write non-finite values to {target}")
    with _thread_pool_of_two():
        write_with(target, lambda tmp: mi.Bitmap(data).write(str(tmp)))


def luminance(rgb: np.ndarray) -> np.ndarray:
    """Rec. 709 luminance of a linear (H, W, 3) image."""
    return rgb @ np.array([0.2126, 0.7152, 0.0722])
