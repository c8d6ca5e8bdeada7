"""SVG files in (render/svg.py) and colour (render/paint.py): matplotlib's own SVG icons,
shapes against their exact areas, arcs within the tolerance, the subset's refusals, and grey
scenes unchanged bit for bit."""

from __future__ import annotations

import hashlib
import io
import math
import os
import sys
import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from edgeaa.cli import main
from edgeaa.model import EdgeConfig
from edgeaa.render import builtin, render_scene
from edgeaa.render.corpus import ICONS
from edgeaa.render.paint import Canvas, coverage_scene, exact_colour, straight
from edgeaa.render.scene import DEFAULT_TOLERANCE, Polygon, Scene, SceneError, parse_path
from edgeaa.render.stroke import area
from edgeaa.render.svg import load_svg

DEFAULT = EdgeConfig()


def icon_file(name: str) -> str:
    import matplotlib

    return os.path.join(matplotlib.get_data_path(), "images", f"{name}.svg")


def write(tmp_path, body: str, attributes: str = 'width="40" height="40"') -> str:
    path = tmp_path / "t.svg"
    path.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" {attributes}>{body}</svg>')
    return str(path)


def colour_render(scene: Scene, config: EdgeConfig = DEFAULT) -> np.ndarray:
    """The straight RGBA image of a colour scene (as the PNG gets it)."""
    canvas = Canvas(scene, config.full_scale)
    render_scene(coverage_scene(scene), config, canvas=canvas)
    return straight(canvas.image, config.full_scale)[0]


def polygon_area(polygon: Polygon) -> float:
    return sum(area(c) for c in polygon.contours)


# -- matplotlib's icons: the SVG reader against the JSON format's path reader ----------------


@pytest.mark.parametrize("name", ICONS)
def test_matplotlib_icons_give_the_image_of_their_paths_read_as_json(name):
    """Both formats parse into one representation: the icon file through svgelements gives
    the contours its path data gives through the JSON format's reader (same size, same
    tolerance in pixels), to float rounding, and the same image."""
    scene = load_svg(icon_file(name), size=(48, 48))
    root = ElementTree.parse(icon_file(name)).getroot()
    box = [float(v) for v in root.get("viewBox").split()]
    scale = 48 / box[2]
    polygons = []
    for element in root.iter("{http://www.w3.org/2000/svg}path"):
        if "fill:none" in element.get("style", "").replace(" ", ""):
            continue
        contours = parse_path(element.get("d"), DEFAULT_TOLERANCE / scale)
        polygons.append(
            # SVG's pixel i covers [i, i + 1], the model's is centred on i
            Polygon(
                tuple(tuple((x * scale - 0.5, y * scale - 0.5) for x, y in c) for c in contours)
            )
        )
    assert len(scene.polygons) == len(polygons) > 0
    assert all(p.paint == (0.0, 0.0, 0.0, 1.0) for p in scene.polygons)  # black, opaque
    for mine, theirs in zip(scene.polygons, polygons, strict=True):
        assert [len(c) for c in mine.contours] == [len(c) for c in theirs.contours]
        for a, b in zip(mine.contours, theirs.contours, strict=True):
            assert np.abs(np.array(a) - np.array(b)).max() < 1e-9, name
    grey = render_scene(coverage_scene(scene), DEFAULT).image
    rgba = colour_render(scene)
    assert np.array_equal(rgba[..., 3], grey) and not rgba[..., :3].any()  # black ink


def test_an_icon_with_gradients_is_refused_or_drawn_without_them():
    with pytest.raises(SceneError, match=r"hand.svg: <path> id='path124' fill='url\("):
        load_svg(icon_file("hand"))
    said = []
    scene = load_svg(icon_file("hand"), size=(64, 64), lenient=True, warn=said.append)
    assert scene.polygons and said and all("gradient" in s for s in said)
    assert len(said) == len(set(said))  # each message once


# -- shapes, transforms, colours ------------------------------------------------------------


def test_shapes_have_their_exact_areas_within_the_flattening_bound(tmp_path):
    """Each shape's polygon area against the true area: the chords cut at most tolerance x
    perimeter (a lens under each chord is thinner than its sagitta)."""
    tol = DEFAULT_TOLERANCE
    cases = [  # (element, exact area, perimeter)
        ('<rect x="2" y="3" width="20" height="10"/>', 200, 60),
        ('<rect x="2" y="3" width="20" height="10" rx="3"/>', 200 - (4 - math.pi) * 9, 60),
        ('<rect x="2" y="3" width="20" height="10" rx="30" ry="2"/>', 200 - (4 - math.pi) * 20, 60),
        ('<circle cx="20" cy="20" r="15"/>', math.pi * 225, 2 * math.pi * 15),
        ('<ellipse cx="20" cy="20" rx="15" ry="5"/>', math.pi * 75, 2 * math.pi * 15),
        ('<polygon points="0,0 30,0 0,30"/>', 450, 103),
        ('<path d="M5 20 A 15 15 0 0 1 35 20 Z"/>', math.pi * 225 / 2, 80),
        ('<path d="M5 20 a 15 15 0 1 0 30 0 z"/>', math.pi * 225 / 2, 80),  # the other half
        ('<path d="M5 20 A 1 1 0 0 1 35 20 Z"/>', math.pi * 225 / 2, 80),  # radius scaled up
        ('<g transform="scale(2 0.5)"><circle cx="10" cy="40" r="8"/></g>', math.pi * 64, 120),
        ('<circle cx="20" cy="20" r="15" transform="skewX(30)"/>', math.pi * 225, 120),
    ]
    for element, exact, perimeter in cases:
        scene = load_svg(write(tmp_path, element))
        (polygon,) = scene.polygons
        assert abs(abs(polygon_area(polygon)) - exact) <= tol * perimeter + 1e-9, element


@settings(max_examples=60, deadline=None)
@given(
    rx=st.floats(0.5, 40), ry=st.floats(0.5, 40), turn=st.floats(0, 360),
    large=st.booleans(), sweep=st.booleans(),
    end=st.tuples(st.floats(-30, 30), st.floats(-30, 30)),
)  # fmt: skip
@example(rx=6.0, ry=1.0, turn=0.0, large=False, sweep=False, end=(0.0, 6.103515625e-05))
def test_arcs_are_flattened_within_the_tolerance(rx, ry, turn, large, sweep, end):
    """Every point of the arc (sampled by svgelements) is within the tolerance of the chords,
    the chords' ends are on the arc, for any radii (out of range ones scaled up), rotation
    and flags."""
    import svgelements as se

    d = f"M 0 0 A {rx} {ry} {turn} {int(large)} {int(sweep)} {end[0]} {end[1]}"
    arc = se.Path(d).segments()[-1]
    if not isinstance(arc, se.Arc) or math.dist((0, 0), end) < 1e-6:
        return
    from edgeaa.render.scene import centre_arc

    flat, tangents = centre_arc(arc, end, DEFAULT_TOLERANCE)
    points = [(0.0, 0.0), *flat]
    t0, swept = arc.get_start_t(), arc.sweep
    # the tangents (for strokes' caps and joins) point along the arc at both ends
    for tangent, t, sign in ((tangents[0], t0, 1), (tangents[1], t0 + swept, -1)):
        step = np.subtract(arc.point_at_t(t + sign * swept * 1e-7), arc.point_at_t(t)) * sign
        unit = np.divide(tangent, math.hypot(*tangent))
        cross = unit[0] * step[1] - unit[1] * step[0]
        # point_at_t rounds each coordinate to about eps * radius: a tiny arc's step carries
        # that much noise across the tangent (seen: 6.6e-16 across a 6.1e-12 step)
        noise = 8 * sys.float_info.epsilon * (arc.rx + arc.ry)
        assert np.dot(unit, step) > 0 and abs(cross) <= 1e-4 * math.hypot(*step) + noise
    samples = [arc.point_at_t(t0 + swept * k / 400) for k in range(401)]
    speed = math.hypot(arc.rx, arc.ry)  # |P'| of the (radius-corrected) ellipse, at most
    for p in points[1:-1]:  # on the ellipse: near a sample (half their spacing)
        assert min(math.dist(p, s) for s in samples) <= abs(swept) * speed / 800 + 1e-6
    for s in samples:
        assert _distance_to_polyline(s, points) <= DEFAULT_TOLERANCE + 1e-6


def _distance_to_polyline(p, points) -> float:
    best = math.inf
    for a, b in zip(points, points[1:], strict=False):
        dx, dy = b[0] - a[0], b[1] - a[1]
        length = dx * dx + dy * dy
        t = (
            0.0
            if length == 0
            else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / length))
        )
        best = min(best, math.dist(p, (a[0] + t * dx, a[1] + t * dy)))
    return best


def test_viewbox_use_style_inheritance_and_colours(tmp_path):
    body = (
        "<style>.b{fill:#00f}</style>"
        '<defs><rect id="r" width="4" height="4"/></defs>'
        '<g fill="currentColor" color="rgb(255,0,0)">'
        '<use href="#r" x="1" y="1"/>'  # red, from currentColor
        '<rect x="6" y="1" width="4" height="4" class="b"/>'  # blue, from the style sheet
        '<rect x="1" y="6" width="4" height="4" style="fill:lime;fill-opacity:0.5"/>'
        '<rect x="6" y="6" width="4" height="4" fill="gold" opacity="0.25"/>'
        "</g>"
    )
    # viewBox 0 0 11 11 on 44 x 22: meet scales by 2 and centres (x 11 .. 33); pixel i is
    # SVG's [i, i + 1]
    scene = load_svg(write(tmp_path, body, 'width="44" height="22" viewBox="0 0 11 11"'))
    rgba = colour_render(scene)
    assert rgba.shape == (22, 44, 4)
    assert tuple(rgba[6, 17]) == (255, 0, 0, 255)  # (2.5, 2.5) in the view box
    assert tuple(rgba[6, 27]) == (0, 0, 255, 255)
    assert tuple(rgba[16, 17]) == (0, 255, 0, 128)  # half opaque lime over transparent
    assert tuple(rgba[16, 27]) == (255, 215, 0, 64)  # gold at a quarter
    assert rgba[:, :10, 3].max() == 0  # meet: nothing left of the centred view box
    sized = load_svg(write(tmp_path, body, 'width="44" height="22" viewBox="0 0 11 11"'), (11, 11))
    assert (sized.width, sized.height) == (11, 11)
    assert tuple(colour_render(sized)[2, 2]) == (255, 0, 0, 255)


def test_colour_composites_source_over_per_channel():
    """Half-covered pixels and alpha: exact premultiplied source-over in integers."""
    square = (((-0.5, -0.5), (3.5, -0.5), (3.5, 3.5), (-0.5, 3.5)),)  # every pixel
    half = (((-0.5, -0.5), (4.5, -0.5), (4.5, 1.0), (-0.5, 1.0)),)  # row 1 half covered
    scene = Scene(
        4, 4, (Polygon(square, paint=(1.0, 0.0, 0.0, 1.0)),
               Polygon(half, paint=(0.0, 0.0, 1.0, 0.5))),
        background_paint=(1.0, 1.0, 1.0, 1.0),
    )  # fmt: skip
    rgba = colour_render(scene)
    assert tuple(rgba[3, 2]) == (255, 0, 0, 255)  # red alone
    assert tuple(rgba[0, 2]) == (127, 0, 128, 255)  # blue at alpha 128/255 over red
    assert tuple(rgba[1, 2]) == (191, 0, 64, 255)  # half of that coverage: 64
    grey = (Polygon(square, 100),)
    assert tuple(colour_render(Scene(4, 4, grey, background_paint=(0, 0, 0, 0)))[2, 2]) == (
        100, 100, 100, 255,
    )  # fmt: skip


GROUPS = (  # pixel-aligned shapes: every coverage is 0 or 1, only the composites differ
    '<rect width="8" height="10" fill="#ffe0c0" opacity="0.75"/>'
    '<g opacity="0.5"><rect width="4" height="2" fill="red"/>'
    '<rect x="2" width="4" height="2" fill="blue"/>'  # over red at x 2..4, inside the layer
    '<g opacity="0.5"><rect y="2" width="2" height="2" fill="lime"/>'
    '<rect x="1" y="2" width="2" height="2" fill="lime"/></g></g>'  # nested: a quarter
    '<rect y="6" width="2" height="2" fill="red" stroke="blue" stroke-width="2" opacity="0.5"/>'
)


def group_render(tmp_path):
    scene = load_svg(write(tmp_path, GROUPS, 'width="8" height="10"'))
    plan = render_scene(coverage_scene(scene), DEFAULT).plan
    canvas = Canvas(scene, DEFAULT.full_scale)
    render_scene(plan, canvas=canvas)
    return scene, plan, canvas.image


def test_group_opacity_composites_the_group_as_a_layer(tmp_path):
    """SVG's group opacity: the children source-over into a transparent layer, the layer
    composited with the opacity (nested: the inner layer into the outer); an element's fill
    and stroke together. Opacity is not inherited: each child at its own."""
    scene, plan, image = group_render(tmp_path)
    assert scene.layers == (0.5, 0.5, 0.5)
    rgba = straight(image, DEFAULT.full_scale)[0]
    # premultiplied: the peach at alpha round(0.75 * 255) = 191 over transparent, each
    # channel round(191 c / 255)
    assert tuple(image[0, 7]) == (191, 168, 144, 191)
    assert tuple(rgba[0, 7]) == (255, 224, 192, 191)  # straight, as the PNG has it
    # blue over red in the layer is blue; the layer at opacity 128 (0.5 rounded half up):
    # (0, 0, 128, 128) + round(peach 127 / 255) = (0, 0, 128, 128) + (95, 84, 72, 95)
    assert tuple(image[1, 3]) == (95, 84, 200, 223)
    assert tuple(image[1, 1]) == (223, 84, 72, 223)  # red alone in the layer
    # nested: the lime union at 128 of 128, round(128 * 128 / 255) = 64, over the peach:
    # (0, 64, 0, 64) + round(peach 191 / 255) = (0, 64, 0, 64) + (143, 126, 108, 143)
    assert tuple(image[2, 1]) == (143, 190, 108, 207)
    # fill and stroke at 0.5 together: the blue stroke covers the red fill in the layer
    assert tuple(image[6, 0]) == (95, 84, 200, 223)
    # within 7/8 LSB of the same composites in real numbers: each rounding is within 1/2 and
    # the error before it is scaled by at most 1/2 (an opacity) or kept (the last composite)
    assert np.abs(image - exact_colour(plan, scene)).max() <= 7 / 8


def test_group_opacity_is_resvgs(tmp_path):
    """The same SVG through resvg, premultiplied, within 2 LSB: edgeaa is within 7/8 of the
    real composite (above); resvg's 8-bit composites round each within 1/2, and its straight
    PNG back to premultiplied within 1/2 more (measured 0.87), so the two are within 2
    after rounding. Without layers the overlaps differ by 30 to 60 LSB."""
    resvg_py = pytest.importorskip("resvg_py")
    from PIL import Image

    _, _, image = group_render(tmp_path)
    data = resvg_py.svg_to_bytes(svg_path=str(tmp_path / "t.svg"), dpi=96.0)
    theirs = np.asarray(Image.open(io.BytesIO(bytes(data))).convert("RGBA")).astype(np.int64)
    alpha = theirs[..., 3:4]
    premultiplied = np.concatenate([(theirs[..., :3] * alpha + 127) // 255, alpha], axis=2)
    assert np.abs(premultiplied - image).max() <= 2


def test_group_opacity_is_refused_by_the_hardware_engines(tmp_path, capsys):
    body = (
        '<g opacity="0.5"><rect width="4" height="2" fill="red"/>'
        '<rect x="2" width="4" height="2"/></g>'
    )
    path, out = write(tmp_path, body, 'width="8" height="8"'), tmp_path / "out.png"
    assert main(["render", path, "--engine", "verilator", "-o", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "group opacity" in err and not out.exists()
    assert main(["render", path, "-o", str(out), "--quiet"]) == 0


def test_linear_light_blends_decoded_colours(tmp_path, capsys):
    """--linear-light: sRGB decoded before the composite, encoded after. White half over
    black is round(255 encode(128 / 255)) = 188 (the model's half coverage is 128 of 255),
    not 128; the image is within 1/2 LSB plus the 16-bit linear steps of the same composites
    in real numbers; the hardware engines and grey scenes refuse it in one line."""
    from dataclasses import replace

    from edgeaa.render.paint import srgb_decode, srgb_encode

    x = np.linspace(0, 1, 1001)
    assert np.abs(srgb_decode(srgb_encode(x)) - x).max() < 1e-12
    assert abs(srgb_decode(0.5) - 0.21404114) < 1e-8  # IEC 61966-2-1
    body = (
        '<rect y="9" width="4" height="1"/><rect x="0.5" y="9" width="2" height="1" fill="white"/>'
    )
    scene = load_svg(write(tmp_path, GROUPS[GROUPS.index("<g") :] + body, 'width="8" height="10"'))
    for linear, half in ((False, 128), (True, 188)):
        lit = replace(scene, linear_light=linear)
        plan = render_scene(coverage_scene(lit), DEFAULT).plan
        canvas = Canvas(lit, DEFAULT.full_scale)
        render_scene(plan, canvas=canvas)
        assert tuple(canvas.image[9, 0]) == (half, half, half, 255)  # row 9: only these
        assert np.abs(canvas.image - exact_colour(plan, lit)).max() <= 1
    assert half == round(255 * float(srgb_encode(128 / 255)))
    path, out = write(tmp_path, body, 'width="4" height="10"'), str(tmp_path / "o.png")
    assert main(["render", path, "-o", out, "--linear-light", "--engine", "amaranth"]) == 2
    grey = tmp_path / "grey.json"
    grey.write_text('{"width": 4, "height": 4, "polygons": [[[0, 0], [3, 0], [0, 3]]]}')
    assert main(["render", str(grey), "-o", out, "--linear-light", "--quiet"]) == 2
    errors = capsys.readouterr().err.splitlines()
    assert len(errors) == 2 and "hardware" in errors[0] and "grey" in errors[1]


BUILTIN_SHA256 = {  # the built-ins' images before colour came (commit 06d729e)
    ("paper", "starburst"): "a76c39b193755467", ("paper", "text"): "c0ae0af5c1f5a23f",
    ("paper", "hatch"): "25f067a7d62b0d05", ("seg4", "starburst"): "0e403839879cebfb",
    ("seg4", "text"): "3a7839eebdef7841", ("seg4", "hatch"): "6eecf145b74c691b",
}  # fmt: skip


@pytest.mark.parametrize(("mode", "name"), sorted(BUILTIN_SHA256))
def test_grey_scenes_are_unchanged_bit_for_bit(mode, name):
    config = EdgeConfig(mode=mode)
    scene = builtin(name, config)
    assert not scene.colour
    image = render_scene(scene, config).image
    assert hashlib.sha256(image.tobytes()).hexdigest()[:16] == BUILTIN_SHA256[mode, name]


# -- the command line -------------------------------------------------------------------------


def test_render_writes_rgba_and_rgb_pngs(tmp_path, capsys):
    from PIL import Image

    out = tmp_path / "icon.png"
    assert main(["render", icon_file("home"), "--scale", "0.5", "-o", str(out), "--quiet"]) == 0
    image = Image.open(out)
    assert image.mode == "RGBA" and image.size == (48, 48)  # 72 pt = 96 px, halved
    opaque = write(
        tmp_path,
        '<rect width="9" height="9" fill="white"/><circle cx="4" cy="4" r="3" fill="#abc"/>',
        'width="9" height="9"',
    )
    out2 = tmp_path / "rgb.png"
    assert main(["render", opaque, "-o", str(out2), "--quiet", "--error", "--json"]) == 0
    assert Image.open(out2).mode == "RGB"
    assert Image.open(out2).getpixel((4, 4)) == (0xAA, 0xBB, 0xCC)
    assert '"max_abs_lsb"' in capsys.readouterr().out


@pytest.mark.parametrize(
    ("body", "argv", "message"),
    [
        ("<text>hi</text>", [], "t.svg: <text> is outside the SVG subset"),
        ('<image href="a.png" width="3" height="3"/>', [], "<image> is outside"),
        ('<rect width="3" height="3" filter="url(#f)"/>', [], "<rect> filter='url(#f)'"),
        ('<rect width="3" height="3" mask="url(#m)"/>', [], "<rect> mask='url(#m)'"),
        ('<circle r="3" clip-path="url(#c)"/>', [], "<circle> clip-path='url(#c)'"),
        ('<circle r="3" vector-effect="non-scaling-stroke"/>', [], "vector-effect="),
        ('<rect width="3" height="3" stroke="red" stroke-dasharray="1 -2"/>', [], "negative"),
        ('<rect width="3" height="3" stroke="red" stroke-linecap="hat"/>', [], "'hat'"),
        ('<path d="M0 0 L 1e9 0 L 0 3 Z"/>', [], "beyond the limit"),
        ('<rect width="3" height="3"', [], "not well-formed XML"),
        ("<rect/>", ["--scale", "900"], "more than the limit"),
        ("<rect/>", ["--size", "3x3", "--scale", "2"], "--size and --scale cannot"),
        ('<circle r="3"/>', ["--coord-bits", "4"], "larger than the coordinate range"),
    ],
)
def test_bad_svg_is_refused_in_one_line(tmp_path, capsys, body, argv, message):
    path = write(tmp_path, body)
    out = tmp_path / "o.png"
    assert main(["render", path, "-o", str(out), "--quiet", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err and "Traceback" not in err, err
    assert not out.exists() and os.listdir(tmp_path) == ["t.svg"]


def test_lenient_skips_with_a_warning_and_svg_options_need_an_svg(tmp_path, capsys):
    path = write(tmp_path, '<text>hi</text><rect width="9" height="9"/>')
    assert main(["render", path, "--lenient", "-o", str(tmp_path / "a.png"), "--quiet"]) == 0
    assert "warning: skipped" in capsys.readouterr().err
    scene = tmp_path / "s.json"
    scene.write_text('{"width": 4, "height": 4, "polygons": []}')
    for option in (["--lenient"], ["--scale", "2"], ["--size", "4x4"]):
        assert main(["render", str(scene), *option]) == 2
        assert "applies to an .svg scene file" in capsys.readouterr().err


def test_strokes_in_svg_have_the_stroked_area(tmp_path):
    """Strokes of a polyline (shapely's buffer), a circle (an annulus), dashed and under a
    non-uniform scale (SVG strokes in the element's own coordinates)."""
    from shapely import affinity
    from shapely.geometry import LineString
    from shapely.geometry import Polygon as ShapelyPolygon
    from shapely.ops import unary_union

    def union_area(polygon: Polygon) -> float:
        return unary_union([ShapelyPolygon(c) for c in polygon.contours]).area

    line = LineString([(5, 5), (30, 5), (30, 30)])
    cases = [
        ('<path d="M5 5 H30 V30" stroke="#000" stroke-width="4" fill="none"/>',
         line.buffer(2, cap_style="flat", join_style="mitre").area, 0),
        ('<path d="M5 5 H30 V30" stroke="#000" stroke-width="4" fill="none" '
         'stroke-linecap="round" stroke-linejoin="round"/>', line.buffer(2, quad_segs=64).area,
         2 * math.pi * 2),
        ('<circle cx="20" cy="20" r="10" stroke="#000" stroke-width="3" fill="none"/>',
         math.pi * (11.5**2 - 8.5**2), 2 * math.pi * 11.5),
        ('<g transform="scale(1 0.5)"><path d="M5 5 H30 V30" stroke="#000" stroke-width="4" '
         'fill="none"/></g>', affinity.scale(line.buffer(2, cap_style="flat", join_style="mitre"),
                                             1, 0.5, origin=(0, 0)).area, 0),
        ('<path d="M5 5 H30 V30" stroke="#000" stroke-width="2" fill="none" '
         'stroke-dasharray="5 5"/>', 2 * 25, 0),  # five dashes of 5 x 2: 50 px
    ]  # fmt: skip
    for element, exact, round_length in cases:
        scene = load_svg(write(tmp_path, element))
        (stroke,) = scene.polygons
        assert stroke.fill_rule == "nonzero" and stroke.name.endswith("stroke")
        assert abs(union_area(stroke) - exact) <= DEFAULT_TOLERANCE * round_length + 1e-6, element


@pytest.mark.parametrize("cap", ["butt", "square"])
@pytest.mark.parametrize(
    ("d", "starts", "ends"),
    [  # path data, the tangent at its start, at its end
        ("M 30 20 A 10 10 0 0 1 20 30", (0, 1), (-1, 0)),  # a quarter circle
        ("M 5 30 C 5 10 30 10 35 22", (0, -1), (5, 12)),
        ("M 5 30 Q 20 0 35 30", (1, -2), (1, 2)),
    ],
)
def test_caps_are_square_to_the_curve(tmp_path, d, starts, ends, cap):
    """A cap ends the stroke at the line through the end square to the curve's tangent
    (butt), or w/2 beyond it (square): nothing of the outline passes that line. With the
    chords' directions the last chord's piece passed it by (w/2)^2 tan(theta) / 2 (theta
    half the chord's turn), 0.2 to 0.7 px^2 on these curves."""
    from shapely.geometry import Polygon as Shape
    from shapely.ops import unary_union

    body = f'<path d="{d}" fill="none" stroke="black" stroke-width="8" stroke-linecap="{cap}"/>'
    (stroke,) = load_svg(write(tmp_path, body)).polygons
    outline = unary_union([Shape(c).buffer(0) for c in stroke.contours])
    numbers = [float(v) for v in d.replace("M", " ").replace("A", " ").split()[-2:]]
    first = [float(v) for v in d.split()[1:3]]
    beyond = 4.0 if cap == "square" else 0.0
    for point, tangent in ((first, np.negative(starts)), (numbers, ends)):
        unit = np.divide(tangent, math.hypot(*tangent))
        end = np.subtract(point, 0.5) + unit * beyond  # the model's pixel centres: -1/2
        # the half-plane past the end line: a large box turned to the tangent
        far = [end + unit * a + np.array([-unit[1], unit[0]]) * b
               for a, b in ((0, -100), (100, -100), (100, 100), (0, 100))]  # fmt: skip
        past = outline.intersection(Shape(far)).area
        assert past <= 1e-9, (point, past)


def test_json_and_svg_give_the_same_polygons_for_arcs_transforms_strokes_colours(tmp_path):
    """The JSON format's transform, arcs, stroke and color read into the polygons an SVG
    file with the same content gives (its -1/2 px pixel shift written into the transform),
    and both render to the same image."""
    from edgeaa.render.scene import parse_scene

    svg = write(
        tmp_path,
        '<path d="M 2 2 A 5 3 20 0 1 15 12 Z" fill="#abc" fill-opacity="0.5"/>'
        '<path d="M 2 2 a 4 6 30 1 1 9 9 l 3 -7" stroke="#336699" stroke-width="1.5" '
        'stroke-linecap="round" stroke-linejoin="bevel" fill="none" '
        'transform="matrix(1 0.2 0 1 3 0)" stroke-dasharray="3 1"/>',
        'width="24" height="24"',
    )
    data = {
        "width": 24, "height": 24, "background_color": [0, 0, 0, 0],
        "polygons": [
            {"path": "M 2 2 A 5 3 20 0 1 15 12 Z", "transform": [1, 0, 0, 1, -0.5, -0.5],
             "color": "#aabbcc80"},  # svgelements keeps fill-opacity 0.5 as 128 / 255
            {"path": "M 2 2 a 4 6 30 1 1 9 9 l 3 -7", "color": "#336699",
             "stroke": {"width": 1.5, "cap": "round", "join": "bevel", "dash": [3, 1]},
             "transform": [1, 0.2, 0, 1, 2.5, -0.5]},
        ],
    }  # fmt: skip
    from_svg, from_json = load_svg(svg), parse_scene(data)
    for a, b in zip(from_svg.polygons, from_json.polygons, strict=True):
        assert (a.fill_rule, len(a.contours)) == (b.fill_rule, len(b.contours))
        assert np.allclose(a.paint, b.paint, atol=1e-12)
        for p, q in zip(a.contours, b.contours, strict=True):
            assert np.abs(np.array(p) - np.array(q)).max() < 1e-9
    assert len(from_json.polygons[1].contours) > 20  # dashes, caps, joins: many pieces
    assert np.array_equal(colour_render(from_svg), colour_render(from_json))


def test_smooth_curves_after_a_line_start_at_the_current_point(tmp_path):
    """S and T reflect the previous control point only after a C/S or Q/T; after a line
    (or an arc) the first control point is the current point (SVG's rule): the JSON reader
    agrees with svgelements' reading of the same path."""
    from edgeaa.render.scene import parse_path

    d = "M0 0 C 0 10 10 10 10 0 L 20 0 S 30 10 30 0 Q 35 -8 40 0 A 3 3 0 0 1 46 0 T 52 0 Z"
    (svg,) = load_svg(write(tmp_path, f'<path d="{d}"/>', 'width="60" height="20"')).polygons
    (json_contour,) = parse_path(d)
    shifted = [(x - 0.5, y - 0.5) for x, y in json_contour]
    assert np.abs(np.array(svg.contours[0]) - np.array(shifted)).max() < 1e-9


def test_json_shapes_are_svgs_shapes(tmp_path):
    """rect (rx, ry, clamped), circle and ellipse in JSON give an SVG file's polygons of the
    same shapes (to 1e-9 px after its -1/2 px shift), filled and stroked."""
    from edgeaa.render.scene import parse_scene

    shapes = [
        ("rect", [1, 2, 10, 6], '<rect x="1" y="2" width="10" height="6"/>'),
        ("rect", [1, 2, 10, 6, 2], '<rect x="1" y="2" width="10" height="6" rx="2"/>'),
        ("rect", [1, 2, 10, 6, 9, 1], '<rect x="1" y="2" width="10" height="6" rx="9" ry="1"/>'),
        ("circle", [15, 15, 5.5], '<circle cx="15" cy="15" r="5.5"/>'),
        ("ellipse", [15, 12, 7, 3], '<ellipse cx="15" cy="12" rx="7" ry="3"/>'),
    ]
    for key, numbers, element in shapes:
        for stroke in (False, True):
            painted = element.replace("/>", ' fill="none" stroke="#000"/>') if stroke else element
            (mine,) = load_svg(write(tmp_path, painted, 'width="30" height="30"')).polygons
            item = {key: numbers, "transform": [1, 0, 0, 1, -0.5, -0.5]}
            if stroke:
                item["stroke"] = {"width": 1}
            (theirs,) = parse_scene({"width": 30, "height": 30, "polygons": [item]}).polygons
            assert len(mine.contours) == len(theirs.contours), (element, stroke)
            for p, q in zip(mine.contours, theirs.contours, strict=True):
                assert np.abs(np.array(p) - np.array(q)).max() < 1e-9, (element, stroke)


def test_a_colour_svg_through_the_verilator_pipeline_is_the_models_png(tmp_path, capsys):
    # Fills, translucent ones and a translucent stroke over a coloured background and a
    # transparent corner: the hardware gives the model's PNG byte for byte (the render also
    # counts mismatching pixels: none).
    body = (
        '<rect width="40" height="36" fill="#203040"/>'
        '<circle cx="15.3" cy="17.2" r="11" fill="orange" fill-opacity="0.7"/>'
        '<path d="M 4 30 Q 20 2 36 30" fill="none" stroke="rgb(20, 200, 120)" stroke-width="3"'
        ' stroke-opacity="0.45"/>'
        '<rect x="22.5" y="20.25" width="14" height="19" rx="3" fill="#00f" opacity="0.3"/>'
    )
    path = write(tmp_path, body)
    outputs = {}
    for engine in ("model", "verilator"):
        outputs[engine] = tmp_path / f"{engine}.png"
        argv = ["render", path, "-o", str(outputs[engine]), "--quiet", "--engine", engine]
        assert main(argv) == 0, capsys.readouterr().err
    assert outputs["model"].read_bytes() == outputs["verilator"].read_bytes()
    image = np.asarray(__import__("PIL.Image").Image.open(outputs["verilator"]))
    assert image.shape == (40, 40, 4) and len({tuple(p) for p in image.reshape(-1, 4)}) > 20
    assert {0, 255} < set(image[..., 3].ravel().tolist())  # translucent, opaque and clear
