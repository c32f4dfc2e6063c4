"""Software renderer: coverage, occlusion, shading, strokes, colour maps, camera fit, files."""

import json
import math
import shutil
import sys
import time

import numpy as np
import pytest
from PIL import Image, ImageSequence

import yore
from yore import Camera, render

WHITE = np.array([255, 255, 255])


def square(n=2, size=1.0, z=0.0):
    """An n×n-vertex flat square of side `size` (m) centred on (0, 0, z), normals towards +z."""
    V, F = yore.grid_mesh(n, n, width=size, height=size)
    return V - [size / 2, size / 2, -z], F


def head_on_camera(width=161, height=121, z=3.0):
    # with odd sizes the world origin projects exactly onto the centre pixel
    return Camera(eye=(0.0, 0.0, z), target=(0.0, 0.0, 0.0), width=width, height=height)


def pixel_at(image, camera, point):
    """The image's colour (int RGB) at the pixel nearest the projection of a 3-D point."""
    x, y = np.rint(camera.project(point)[0]).astype(int)
    return image[y, x].astype(int)


def cloth_mask(image, background=WHITE):
    return np.any(image != background, axis=2)


def shoelace_area(corners):
    x, y = corners[:, 0], corners[:, 1]
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def oblique_square():
    V, F = square(n=9)
    camera = Camera(eye=(0.8, 0.6, 2.5), target=(0.0, 0.0, 0.0), width=400, height=300)
    corners = camera.project(V[[0, 8, 80, 72]])  # counter-clockwise corners of the 9×9 grid
    return V, F, camera, corners


def test_image_has_the_camera_size_and_is_uint8_rgb():
    V, F = square()
    camera = head_on_camera(width=123, height=77)
    image = render.render_image(V, F, camera)
    assert image.shape == (77, 123, 3) and image.dtype == np.uint8
    assert cloth_mask(image).any()
    empty = render.render_image(np.zeros((0, 3)), np.zeros((0, 3), int), camera)
    assert empty.shape == (77, 123, 3) and not cloth_mask(empty).any()


def test_flat_square_covers_its_projected_area():
    V, F, camera, corners = oblique_square()
    image = render.render_image(V, F, camera)
    expected = shoelace_area(corners)
    assert expected > 10_000  # big enough for the tolerance below to mean something
    # Counting pixel centres inside a polygon misses or adds at most part of the boundary
    # pixels, and those errors largely cancel: 0.1 % here; 2 % would catch a lost triangle
    # (1/128 of the area) only together with other errors, a wrong projection surely.
    assert cloth_mask(image).sum() == pytest.approx(expected, rel=0.02)


def test_shared_edges_leave_no_cracks():
    V, F, camera, corners = oblique_square()
    image = render.render_image(V, F, camera)
    y, x = np.mgrid[0:camera.height, 0:camera.width]
    # signed distances (px) of every pixel centre to the four sides of the convex quad
    inside = np.ones(x.shape, dtype=bool)
    for a, b in zip(corners, np.roll(corners, -1, axis=0)):
        edge = b - a
        distance = (edge[0] * (y - a[1]) - edge[1] * (x - a[0])) / np.hypot(*edge)
        inside &= distance * np.sign(shoelace_area_signed(corners)) > 1.0
    assert inside.sum() > 10_000
    assert cloth_mask(image)[inside].all()


def shoelace_area_signed(corners):
    x, y = corners[:, 0], corners[:, 1]
    return 0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


@pytest.mark.parametrize("near_first", [True, False])
def test_nearer_face_hides_farther_face_whatever_the_face_order(near_first):
    near_V, near_F = square(z=0.5)
    far_V, far_F = square(z=0.0)
    camera = head_on_camera()
    options = dict(value_range=(0.0, 1.0), colormap="viridis")
    near_alone = render.render_image(near_V, near_F, camera, face_values=[0.0, 0.0], **options)
    far_alone = render.render_image(far_V, far_F, camera, face_values=[1.0, 1.0], **options)
    parts = [(near_V, near_F, 0.0), (far_V, far_F, 1.0)]
    if not near_first:
        parts.reverse()
    V = np.concatenate([parts[0][0], parts[1][0]])
    F = np.concatenate([parts[0][1], parts[1][1] + len(parts[0][0])])
    values = [parts[0][2]] * 2 + [parts[1][2]] * 2
    both = render.render_image(V, F, camera, face_values=values, **options)
    centre = both[camera.height // 2, camera.width // 2]
    assert np.array_equal(centre, near_alone[camera.height // 2, camera.width // 2])
    assert np.abs(centre.astype(int) - far_alone[camera.height // 2, camera.width // 2]).sum() > 100


def rotated_about_y(V, degrees):
    angle = math.radians(degrees)
    rotation = np.array([[math.cos(angle), 0, math.sin(angle)], [0, 1, 0],
                         [-math.sin(angle), 0, math.cos(angle)]])
    return V @ rotation.T


def test_face_seen_head_on_is_brighter_than_tilted_by_60_degrees():
    V, F = square()
    camera = head_on_camera()
    head_on = pixel_at(render.render_image(V, F, camera), camera, [0.1, -0.2, 0.0]).sum()
    tilted = pixel_at(render.render_image(rotated_about_y(V, 60.0), F, camera), camera,
                      [0.0, -0.2, 0.0]).sum()
    assert head_on > tilted + 100
    # Lambert: ambient + diffuse·cos 60°; the light comes from the eye, not from infinity, so
    # cos θ at the faces' centroids differs from 0.5 and 1 by a few hundredths.
    assert tilted / head_on == pytest.approx(render.AMBIENT + render.DIFFUSE * 0.5, abs=0.03)


def test_back_faces_are_darker_than_front_faces():
    V, F = square()
    front_camera = head_on_camera(z=3.0)
    back_camera = head_on_camera(z=-3.0)
    front = pixel_at(render.render_image(V, F, front_camera), front_camera, [0.1, -0.2, 0]).sum()
    back = pixel_at(render.render_image(V, F, back_camera), back_camera, [0.1, -0.2, 0]).sum()
    # both seen head-on, so only the back-face factor differs (to within rounding to bytes)
    assert back / front == pytest.approx(render.BACK_FACE_SHADE, abs=0.01)


def test_stroke_is_drawn_in_red_along_its_polyline():
    V, F = square(n=5)
    camera = head_on_camera()
    stroke = np.array([[-0.4, -0.3, 0.01], [0.0, 0.1, 0.01], [0.45, 0.35, 0.01]])
    image = render.render_image(V, F, camera, strokes=[stroke])
    samples = np.concatenate([a + np.linspace(0, 1, 25)[:, None] * (b - a)
                              for a, b in zip(stroke[:-1], stroke[1:])])
    for point in samples:
        r, g, b = pixel_at(image, camera, point)
        assert r > 200 and g < 80 and b < 80
    # the line is thin: away from it the cloth colour remains
    r, g, b = pixel_at(image, camera, [0.3, -0.3, 0.0])
    assert b > r


def test_a_stroke_behind_the_cloth_is_hidden_and_one_on_it_shows():
    V, F = square(n=5)  # the square in z = 0, seen from +z
    camera = head_on_camera()
    behind = np.array([[-0.3, -0.2, -0.2], [0.3, -0.2, -0.2]])  # 0.2 m behind the cloth
    on_it = np.array([[-0.3, 0.2, 0.0], [0.3, 0.2, 0.0]])  # exactly on the surface
    image = render.render_image(V, F, camera, strokes=[behind, on_it])
    for x in np.linspace(-0.25, 0.25, 11):
        r, g, b = pixel_at(image, camera, [x, -0.2, -0.2])
        assert b > r  # the cloth's colour: the stroke is occluded
        r, g, b = pixel_at(image, camera, [x, 0.2, 0.0])
        assert r > 200 and g < 80 and b < 80
    # with nothing in front, the same stroke shows
    alone = render.render_image(V[:0], F[:0], camera, strokes=[behind])
    r, g, b = pixel_at(alone, camera, [0.0, -0.2, -0.2])
    assert r > 200 and g < 80 and b < 80


def test_stroke_points_behind_the_camera_are_clipped_away():
    V, F = square()
    camera = head_on_camera(z=3.0)
    # from in front of the cloth to behind the eye (z > 3)
    stroke = np.array([[0.2, 0.1, 0.0], [0.2, 0.1, 6.0]])
    image = render.render_image(V, F, camera, strokes=[stroke, [[0.0, 0.0, 9.0]]])
    r, g, b = pixel_at(image, camera, [0.2, 0.1, 0.0])
    assert r > 200 and g < 80 and b < 80


def test_triangles_crossing_the_camera_plane_are_clipped_not_dropped():
    # A ground plane 0.5 m below an eye looking along −z, made of 5 m cells: the cell that
    # fills the bottom of the view reaches behind the eye.
    V, F = yore.grid_mesh(3, 3, width=10.0, height=10.0)
    V = np.column_stack([V[:, 0] - 5.0, np.full(len(V), -0.5), V[:, 1] - 7.0])
    camera = Camera(eye=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0), width=160, height=120)
    mask = cloth_mask(render.render_image(V, F, camera, edges=True))
    assert mask[-1].all() and not mask[0].any()
    # the plane's far edge, 7 m ahead, is a horizontal line in the image
    far_edge = camera.project([[0.0, -0.5, -7.0]])[0, 1]
    assert not mask[: math.floor(far_edge) + 1].any() and mask[math.ceil(far_edge):].all()


def test_mesh_behind_the_camera_gives_the_background():
    V, F = square(z=5.0)
    image = render.render_image(V, F, head_on_camera(z=3.0))
    assert not cloth_mask(image).any()


def test_face_values_at_the_range_ends_get_the_colour_map_ends():
    V, F = square()
    camera = head_on_camera()
    image = render.render_image(V, F, camera, face_values=[0.0, 1.0], value_range=(0.0, 1.0))
    low = pixel_at(image, camera, [0.25, -0.25, 0.0])  # face 0, below the diagonal
    high = pixel_at(image, camera, [-0.25, 0.25, 0.0])  # face 1
    assert np.abs(low - high).sum() > 150
    assert low[2] > low[0] + 80 and high[0] > high[2] + 80  # coolwarm: blue to red


def test_coolwarm_default_range_centres_untouched_faces_on_the_neutral_colour():
    V, F = square()
    camera = head_on_camera()
    image = render.render_image(V, F, camera, face_values=[1.0, 1.3])
    neutral = pixel_at(image, camera, [0.25, -0.25, 0.0])
    expanded = pixel_at(image, camera, [-0.25, 0.25, 0.0])
    assert neutral.max() - neutral.min() < 10  # grey
    assert expanded[0] > expanded[2] + 80  # red end: 1.3 is the range's top


def test_edges_darken_a_thin_wireframe():
    V, F, camera, _ = oblique_square()
    plain = render.render_image(V, F, camera).astype(int)
    wire = render.render_image(V, F, camera, edges=True).astype(int)
    assert np.all(wire <= plain)
    darkened = np.any(wire < plain, axis=2).sum() / cloth_mask(plain).sum()
    # ~20 px cells with three ~1 px lines each darken a fifth of the cloth
    assert 0.05 < darkened < 0.5


def test_fit_camera_sees_every_point():
    rng = np.random.default_rng(3)
    grid, _ = yore.grid_mesh(11, 7, width=2.0, height=0.5)
    point_sets = [
        rng.normal(size=(200, 3)) * [1.0, 3.0, 0.2] + [5.0, -2.0, 1.0],
        grid,
        np.column_stack([np.linspace(0, 10, 50), np.zeros(50), np.linspace(0, 0.01, 50)]),
        [grid, grid + [0.0, -1.5, 0.8], grid * 1.3],  # frames of a run
        np.array([[1.0, 2.0, 3.0]]),
    ]
    for points in point_sets:
        for width, height in ((800, 600), (300, 500)):
            camera = render.fit_camera(points, width=width, height=height)
            everything = np.concatenate(points) if isinstance(points, list) else points
            pixels = camera.project(everything)
            assert np.all(pixels >= -0.5)
            assert np.all(pixels <= [width - 0.5, height - 0.5])


def test_fit_camera_is_tight_for_a_sphere():
    rng = np.random.default_rng(4)
    directions = rng.normal(size=(2000, 3))
    sphere = directions / np.linalg.norm(directions, axis=1, keepdims=True) + [1.0, 2.0, 3.0]
    camera = render.fit_camera(sphere, width=640, height=480, margin=1.08)
    extent = np.ptp(camera.project(sphere), axis=0)
    # the silhouette spans tan(asin(sin(17.5°)/1.08)) / tan(17.5°) ≈ 92 % of the height
    assert extent == pytest.approx([0.92 * 480] * 2, rel=0.03)


def test_side_by_side_concatenates_with_gaps_and_titles():
    rng = np.random.default_rng(5)
    images = [rng.integers(0, 256, size=(40, width, 3), dtype=np.uint8) for width in (30, 50)]
    joined = render.side_by_side(images, titles=["left", "right"], gap=8, title_height=28)
    assert joined.shape == (40 + 28, 30 + 8 + 50, 3) and joined.dtype == np.uint8
    assert np.array_equal(joined[28:, :30], images[0])
    assert np.array_equal(joined[28:, 38:], images[1])
    assert np.all(joined[28:, 30:38] == 255)
    assert np.any(joined[:28] < 128)  # the titles are drawn in dark ink
    assert render.side_by_side(images, gap=0).shape == (40, 80, 3)
    with pytest.raises(ValueError, match="heights"):
        render.side_by_side([images[0], images[1][:20]])


def test_save_png_round_trips(tmp_path):
    image = np.random.default_rng(6).integers(0, 256, size=(17, 23, 3), dtype=np.uint8)
    path = render.save_png(tmp_path / "deep" / "folder" / "picture.png", image)
    assert path.exists()
    assert np.array_equal(np.asarray(Image.open(path).convert("RGB")), image)
    with pytest.raises(ValueError, match="image must have dtype uint8"):
        render.save_png(tmp_path / "bad.png", image.astype(float))
    with pytest.raises(ValueError, match=r"image must have shape \(h, w, 3\)"):
        render.save_png(tmp_path / "bad.png", image[:, :, 0])


def test_gif_has_every_frame_and_loops(tmp_path):
    frames = [np.full((12, 16, 3), 60 * k, dtype=np.uint8) for k in range(4)]
    path = render.save_animation(tmp_path / "run" / "cloth.gif", frames, fps=10.0)
    with Image.open(path) as gif:
        assert sum(1 for _ in ImageSequence.Iterator(gif)) == 4
        assert gif.info["loop"] == 0
        assert gif.info["duration"] == 100  # ms at 10 frames per second


def test_animation_rejects_unknown_suffixes_and_no_frames(tmp_path):
    frame = np.zeros((4, 4, 3), dtype=np.uint8)
    with pytest.raises(ValueError, match=r"\.gif, \.mp4"):
        render.save_animation(tmp_path / "cloth.avi", [frame])
    with pytest.raises(ValueError, match="images is empty"):
        render.save_animation(tmp_path / "cloth.gif", [])
    with pytest.raises(ValueError, match=r"images\[1\] has shape"):
        render.save_animation(tmp_path / "cloth.gif", [frame, np.zeros((4, 6, 3), np.uint8)])


def test_mp4_without_ffmpeg_says_so_and_suggests_gif(tmp_path, monkeypatch):
    monkeypatch.setattr(shutil, "which", lambda name: None)
    with pytest.raises(ValueError, match=r"ffmpeg.*\.gif"):
        render.save_animation(tmp_path / "cloth.mp4", [np.zeros((4, 4, 3), dtype=np.uint8)])


def fake_ffmpeg(tmp_path, body):
    script = tmp_path / "ffmpeg"
    script.write_text(f"#!{sys.executable}\nimport json, sys\n{body}\n")
    script.chmod(0o755)
    return str(script)


def test_mp4_pipes_even_sized_rgb_frames_to_ffmpeg(tmp_path, monkeypatch):
    # A stand-in ffmpeg records its arguments and how many bytes it was fed.
    ffmpeg = fake_ffmpeg(tmp_path, "data = sys.stdin.buffer.read()\n"
                         "open(sys.argv[-1], 'w').write(json.dumps([sys.argv[1:], len(data)]))")
    monkeypatch.setattr(shutil, "which", lambda name: ffmpeg if name == "ffmpeg" else None)
    frames = [np.full((5, 7, 3), k, dtype=np.uint8) for k in range(3)]
    path = render.save_animation(tmp_path / "cloth.mp4", frames, fps=24.0)
    arguments, byte_count = json.loads(path.read_text())
    assert byte_count == 3 * 6 * 8 * 3  # padded to 8×6, rgb24
    assert arguments[arguments.index("-video_size") + 1] == "8x6"
    assert {"libx264", "yuv420p"} <= set(arguments)


def test_mp4_reports_ffmpeg_failure(tmp_path, monkeypatch):
    ffmpeg = fake_ffmpeg(tmp_path, "sys.stderr.write('codec exploded'); sys.exit(3)")
    monkeypatch.setattr(shutil, "which", lambda name: ffmpeg)
    with pytest.raises(RuntimeError, match="codec exploded"):
        render.save_animation(tmp_path / "cloth.mp4", [np.zeros((64, 64, 3), np.uint8)] * 20)


@pytest.mark.skipif(shutil.which("ffmpeg") is None, reason="ffmpeg is not installed")
def test_mp4_with_real_ffmpeg(tmp_path):
    frames = [np.full((31, 45, 3), 8 * k, dtype=np.uint8) for k in range(10)]
    path = render.save_animation(tmp_path / "cloth.mp4", frames, fps=15.0)
    assert path.stat().st_size > 0


def bad_inputs():
    V, F = square()
    return [
        (dict(V=np.where(np.arange(12).reshape(4, 3) == 4, np.nan, V)), "^V must be finite"),
        (dict(V=V[:, :2]), r"^V must have shape \(k, 3\), got \(4, 2\)"),
        (dict(F=F + 2), "^F holds vertex index 5"),
        (dict(F=np.array([[0, 1, 2, 3]])), r"^F must have shape \(f, 3\), got \(1, 4\)"),
        (dict(face_values=[1.0, 2.0, 3.0]), r"^face_values must have shape \(2,\)"),
        (dict(face_values=[1.0, 2.0], value_range=(2.0, 1.0)), "^value_range"),
        (dict(face_values=[1.0, 2.0], colormap="jet"), "^colormap must be one of"),
        (dict(strokes=[np.zeros((3, 2))]), r"^strokes\[0\] must have shape"),
        (dict(color=(0.0, 2.0, 0.0)), "^color"),
    ]


@pytest.mark.parametrize("change, message", bad_inputs())
def test_invalid_input_raises_value_error_naming_the_argument(change, message):
    V, F = square()
    arguments = dict(V=V, F=F, camera=head_on_camera())
    arguments.update(change)
    with pytest.raises(ValueError, match=message):
        render.render_image(**arguments)


# -- image sizes are bounded before anything is allocated --------------------------------------


@pytest.mark.parametrize("width, height", [(30000, 600), (16000, 16000), (0, 10), (2.5, 10),
                                           (True, 10), ("800", 600)])
def test_a_camera_too_large_or_of_the_wrong_type_is_refused(width, height):
    with pytest.raises(ValueError, match="camera (width|height|image size)") as caught:
        yore.Camera(eye=(0, 0, 3), target=(0, 0, 0), width=width, height=height)
    assert "\n" not in str(caught.value)


def test_fit_camera_refuses_a_30000_pixel_image_before_rendering():
    V, F = yore.grid_mesh(3, 3)
    with pytest.raises(ValueError, match="fit_camera width: got int 30000"):
        yore.render.fit_camera(V, width=30000, height=600)
    with pytest.raises(ValueError, match="more than the limit of 8388608 pixels"):
        yore.render.fit_camera(V, width=4000, height=4000)


def test_side_by_side_refuses_a_huge_title_band():
    image = np.zeros((4, 4, 3), dtype=np.uint8)
    with pytest.raises(ValueError, match="side_by_side"):
        yore.render.side_by_side([image], titles=["a"], title_height=10**9)
