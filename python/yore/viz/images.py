"""Images as arrays and files: panels side by side with titles, overlays (titles, colour
bars), PNG, animated GIF (Pillow) and MP4 (ffmpeg). Pure numpy + Pillow: no OpenGL here."""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from ..checks import MAX_IMAGE_PIXELS, check_count, check_factor, check_image
from ..io import write_atomically

__all__ = [
    "side_by_side",
    "save_png",
    "save_animation",
    "check_ffmpeg",
    "draw_title",
    "draw_colorbar",
    "font",
]

_ANIMATION_SUFFIXES = (".gif", ".mp4")


def _check_byte_rgb(rgb, name):
    try:
        value = np.asarray(rgb)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be 3 integers in [0, 255], got {rgb!r}") from None
    if (
        value.shape != (3,)
        or value.dtype.kind not in "iu"
        or not np.all((value >= 0) & (value <= 255))
    ):
        raise ValueError(f"{name} must be 3 integers in [0, 255] (RGB), got {rgb!r}")
    return value.astype(np.uint8)


def font(size):
    """Pillow's built-in font at about ``size`` pixels (scalable where FreeType is there)."""
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=max(8, int(size)))
    except (TypeError, ImportError, OSError):
        return ImageFont.load_default()


#: Pixels between neighbouring images of `side_by_side`, and the height of its title band.
SIDE_BY_SIDE_GAP = 8
TITLE_HEIGHT = 28


def side_by_side_shape(widths, height, titled, gap=SIDE_BY_SIDE_GAP, title_height=TITLE_HEIGHT):
    """(height, width) in pixels of `side_by_side`'s canvas for images of these widths and
    one height: known before anything is rendered (a run checks its pictures up front)."""
    return ((title_height if titled else 0) + height, sum(widths) + gap * (len(widths) - 1))


# over 60 lines: a docstring for its 5 parameters (the code is 36 lines)
def side_by_side(
    images, titles=None, gap=SIDE_BY_SIDE_GAP, title_height=TITLE_HEIGHT, background=(255, 255, 255)
) -> np.ndarray:
    """Places equal-height images left to right, with optional titles above them.

    Parameters
    ----------
    images : sequence of (h, w_i, 3) uint8 arrays
        At least one; all of the same height h.
    titles : sequence of str, optional
        One per image, drawn centred in a band of ``title_height`` pixels above it with Pillow's
        default font. Without titles there is no band.
    gap : int
        Pixels of background between neighbouring images (>= 0).
    title_height : int
        Height of the title band in pixels (>= 0).
    background : 3 ints in [0, 255]
        RGB colour of the gaps and the title band.

    Returns
    -------
    (h + title_height if titles else h, Σ w_i + gap·(len(images) − 1), 3) uint8 array

    Raises
    ------
    ValueError
        If there are no images, an image is not (h, w, 3) uint8, heights differ, the number of
        titles differs from the number of images, or gap, title_height or background is invalid.
    """
    images = [check_image(image, f"images[{i}]") for i, image in enumerate(images)]
    if not images:
        raise ValueError("images is empty: side_by_side needs at least one image")
    heights = {image.shape[0] for image in images}
    if len(heights) != 1:
        raise ValueError(f"images must have equal heights, got {[im.shape[0] for im in images]}")
    gap = check_count(gap, "gap")
    title_height = check_count(title_height, "title_height")
    background = _check_byte_rgb(background, "background")
    if titles is not None:
        titles = [str(title) for title in titles]
        if len(titles) != len(images):
            raise ValueError(
                f"titles must have one entry per image ({len(images)}), got {len(titles)}"
            )
    band = title_height if titles is not None else 0
    height = images[0].shape[0]
    total_width = side_by_side_shape(
        [image.shape[1] for image in images], height, titles is not None, gap, title_height
    )[1]
    if (band + height) * total_width > len(images) * MAX_IMAGE_PIXELS:
        raise ValueError(
            f"side_by_side: a {total_width}×{band + height} canvas is more than "
            f"{MAX_IMAGE_PIXELS} pixels per image (gap {gap}, title_height "
            f"{title_height})"
        )
    canvas = np.empty((band + height, total_width, 3), dtype=np.uint8)
    canvas[:] = background
    lefts = np.cumsum([0] + [image.shape[1] + gap for image in images[:-1]])
    for left, image in zip(lefts, images):
        canvas[band:, left : left + image.shape[1]] = image
    if titles is not None and band > 0:
        canvas[:band] = _draw_titles(
            canvas[:band], titles, lefts, [image.shape[1] for image in images], background
        )
    return canvas


def _draw_titles(band, titles, lefts, widths, background):
    """The title band (uint8 array) with each title centred over its image."""
    from PIL import Image, ImageDraw

    height = band.shape[0]
    face = font(0.55 * height)
    # Dark text on light backgrounds, light text on dark ones (Rec. 601 luma).
    luma = 0.299 * background[0] + 0.587 * background[1] + 0.114 * background[2]
    ink = (25, 25, 25) if luma >= 128 else (235, 235, 235)
    picture = Image.fromarray(np.ascontiguousarray(band))
    draw = ImageDraw.Draw(picture)
    for title, left, width in zip(titles, lefts, widths):
        x0, y0, x1, y1 = draw.textbbox((0, 0), title, font=face)
        # Centred over the image; a title wider than its image starts at the image's left edge.
        x = int(left) + max((width - (x1 - x0)) // 2, 0) - x0
        y = (height - (y1 - y0)) // 2 - y0
        draw.text((x, y), title, fill=ink, font=face)
    return np.asarray(picture)


def save_png(path, image) -> Path:
    """Writes an (h, w, 3) uint8 RGB image as PNG (atomically: a temporary file renamed),
    creating parent folders; returns the path.

    Raises ValueError if the image is not (h, w, 3) uint8 or the path does not end in ".png".
    """
    from PIL import Image

    image = check_image(image, "image")
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ValueError(f"save_png writes PNG files; path must end in .png, got {str(path)!r}")
    return write_atomically(path, lambda target: Image.fromarray(image).save(target, format="PNG"))


def save_animation(path, images, fps=15.0) -> Path:
    """Writes equal-size (h, w, 3) uint8 frames as an animated GIF or an MP4; returns the path.

    ``.gif`` is written with Pillow and loops forever. GIF frame delays are whole hundredths
    of a second, so the frame rate is approximate, many viewers slow delays below 0.02 s down,
    and Pillow merges identical consecutive frames into one longer frame.

    ``.mp4`` pipes raw RGB frames to ``ffmpeg`` (looked up on PATH) for H.264 in yuv420p, which
    needs even sizes: an odd width or height is padded by repeating the last column or row.

    Parent folders are created.

    Raises
    ------
    ValueError
        If the suffix is not .gif or .mp4, there are no frames, a frame is not (h, w, 3) uint8
        or differs in size from the first, fps is not finite and > 0, or for .mp4 when ffmpeg
        is not installed.
    RuntimeError
        If ffmpeg fails (its error output is in the message).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in _ANIMATION_SUFFIXES:
        raise ValueError(
            f"unsupported animation format {path.suffix!r} in {str(path)!r}; "
            f"supported: {', '.join(_ANIMATION_SUFFIXES)}"
        )
    frames = [check_image(image, f"images[{i}]") for i, image in enumerate(images)]
    if not frames:
        raise ValueError("images is empty: an animation needs at least one frame")
    for i, frame in enumerate(frames):
        if frame.shape != frames[0].shape:
            raise ValueError(
                f"images[{i}] has shape {frame.shape}, but images[0] has "
                f"{frames[0].shape}; all frames must have the same size"
            )
    fps = check_factor(fps, "fps")
    if suffix == ".gif":
        _save_gif(path, frames, fps)
    else:
        _save_mp4(path, frames, fps)
    return path


def _save_gif(path, frames, fps):
    from PIL import Image

    pictures = [Image.fromarray(frame) for frame in frames]
    write_atomically(
        path,
        lambda target: pictures[0].save(
            target,
            format="GIF",
            save_all=True,
            append_images=pictures[1:],
            duration=max(int(round(1000.0 / fps)), 1),
            loop=0,
        ),
    )


def check_ffmpeg() -> str:
    """The path of ``ffmpeg`` (what MP4 animations need); ValueError when it is not on PATH."""
    ffmpeg = shutil.which("ffmpeg")
    if ffmpeg is None:
        raise ValueError(
            "an MP4 animation needs ffmpeg, which is not on PATH; install ffmpeg "
            "or save the animation as .gif instead"
        )
    return ffmpeg


def _save_mp4(path, frames, fps):
    write_atomically(path, lambda target: _encode_mp4(target, path, frames, fps))


def _encode_mp4(target, path, frames, fps):
    ffmpeg = check_ffmpeg()
    height, width = frames[0].shape[:2]
    pad = ((0, height % 2), (0, width % 2), (0, 0))
    command = [
        ffmpeg,
        "-y",
        "-loglevel",
        "error",
        "-f",
        "rawvideo",
        "-pixel_format",
        "rgb24",
        "-video_size",
        f"{width + width % 2}x{height + height % 2}",
        "-framerate",
        repr(float(fps)),
        "-i",
        "-",
        "-an",
        "-c:v",
        "libx264",
        "-pix_fmt",
        "yuv420p",
        "-movflags",
        "+faststart",
        str(target),
    ]
    # ffmpeg's messages go to a file rather than a pipe: an unread pipe that fills up would
    # block ffmpeg while we block writing frames to it.
    with tempfile.TemporaryFile() as errors:
        process = subprocess.Popen(
            command, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=errors
        )
        try:
            for frame in frames:
                process.stdin.write(np.pad(frame, pad, mode="edge").tobytes())
        except BrokenPipeError:
            pass  # ffmpeg stopped early; its exit status and message say why
        finally:
            try:
                process.stdin.close()
            except BrokenPipeError:
                pass
            status = process.wait()
        if status != 0:
            errors.seek(0)
            message = errors.read().decode(errors="replace").strip()
            raise RuntimeError(
                f"ffmpeg failed with exit status {status} writing {str(path)!r}: {message}"
            )


def draw_title(image, title, band=None) -> np.ndarray:
    """``image`` with ``title`` written centred in its top ``band`` pixels (default: about 7 %
    of the height), dark on the band's background."""
    from PIL import Image, ImageDraw

    image = check_image(image, "image")
    height, width = image.shape[:2]
    band = int(band or max(14, min(0.07 * height, 40)))
    face = font(0.6 * band)
    picture = Image.fromarray(image)
    draw = ImageDraw.Draw(picture)
    x0, y0, x1, y1 = draw.textbbox((0, 0), str(title), font=face)
    draw.text(
        (max((width - (x1 - x0)) // 2, 2) - x0, (band - (y1 - y0)) // 2 - y0),
        str(title),
        fill=(20, 20, 20),
        font=face,
    )
    return np.asarray(picture)


def draw_colorbar(image, table, value_range, label, left=None, ticks=5) -> np.ndarray:
    """``image`` with a vertical colour bar in its columns from ``left`` on (default: the
    right 20 %): ``table`` (n×3 RGB in [0, 1], low first) spanning ``value_range``, ``ticks``
    labelled values and ``label`` above the bar."""
    from PIL import Image, ImageDraw

    image = check_image(image, "image")
    height, width = image.shape[:2]
    left = int(width - 0.2 * width if left is None else left)
    low, high = (float(v) for v in value_range)
    table = np.asarray(table, dtype=np.float64)
    strip = width - left
    size = max(9.0, min(0.035 * height, 0.16 * strip, 20.0))
    face = font(size)
    bar_height = int(0.6 * height)
    bar_width = max(6, int(0.12 * strip))
    labels = [_tick(low + (high - low) * k / (ticks - 1), high - low) for k in range(ticks)]
    picture = Image.fromarray(image)
    draw = ImageDraw.Draw(picture)
    pad = max(2, int(0.5 * size))
    top = (height - bar_height) // 2
    label_face, label_size = face, size
    label_box = draw.textbbox((0, 0), label, font=label_face)
    while label_box[2] - label_box[0] > strip - 2 * pad and label_size > 7:
        # a long label gets a smaller font, so it fits the strip
        label_size -= 1
        label_face = font(label_size)
        label_box = draw.textbbox((0, 0), label, font=label_face)
    draw.text(
        (left + pad - label_box[0], top - pad - label_box[3]),
        label,
        fill=(20, 20, 20),
        font=label_face,
    )
    bar_left = left + pad
    rows = np.linspace(1.0, 0.0, bar_height)
    colours = np.column_stack(
        [np.interp(rows, np.linspace(0, 1, len(table)), table[:, c]) for c in range(3)]
    )
    strip_pixels = np.repeat(
        (np.clip(colours, 0, 1) * 255 + 0.5).astype(np.uint8)[:, None, :], bar_width, axis=1
    )
    picture.paste(Image.fromarray(strip_pixels), (bar_left, top))
    draw.rectangle(
        (bar_left, top, bar_left + bar_width - 1, top + bar_height - 1), outline=(60, 60, 60)
    )
    for k, text in enumerate(labels):
        y = top + bar_height - 1 - round(k * (bar_height - 1) / (ticks - 1))
        draw.line((bar_left + bar_width, y, bar_left + bar_width + pad, y), fill=(60, 60, 60))
        box = draw.textbbox((0, 0), text, font=face)
        draw.text(
            (bar_left + bar_width + 2 * pad - box[0], y - (box[3] + box[1]) // 2),
            text,
            fill=(20, 20, 20),
            font=face,
        )
    return np.asarray(picture)


def _tick(value, span) -> str:
    """A tick label with as many digits as the span needs."""
    if value == 0 or abs(value) < 1e-12 * max(span, 1e-300):
        return "0"
    digits = max(0, int(np.ceil(-np.log10(span / 4.0))) + (1 if span < 4 else 0))
    if abs(value) >= 1e4 or abs(value) < 1e-3:
        return f"{value:.2e}"
    return f"{value:.{min(digits, 6)}f}"
