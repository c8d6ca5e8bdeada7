"""Draw a scene file with AGG (aggdraw) or Skia alone, as a program using them would: read
the JSON, build each polygon's path, rasterize, write the PNG. No edgeaa imports, so the
process's peak memory is the peer's (benchmarks/bench_stages.py runs it in a subprocess).

    python benchmarks/peer_draw.py {agg,skia} SCENE.json OUT.png
"""

import json
import sys


def agg(scene, out):
    import aggdraw
    from PIL import Image

    image = Image.new("L", (scene["width"], scene["height"]), scene.get("background", 0))
    draw = aggdraw.Draw(image)
    pen = aggdraw.Pen(0, 0, 0)
    for poly in scene["polygons"]:
        path = aggdraw.Path()
        for contour in poly["contours"]:
            path.moveto(contour[0][0] + 0.5, contour[0][1] + 0.5)
            for x, y in contour[1:]:
                path.lineto(x + 0.5, y + 0.5)
            path.close()
        draw.path(path, pen, aggdraw.Brush(poly.get("intensity", 255)))
    draw.flush()
    image.save(out)


def skia(scene, out):
    import skia

    surface = skia.Surface(scene["width"], scene["height"])
    canvas = surface.getCanvas()
    b = scene.get("background", 0)
    canvas.clear(skia.ColorSetRGB(b, b, b))
    for poly in scene["polygons"]:
        path = skia.Path()
        for contour in poly["contours"]:
            path.moveTo(contour[0][0] + 0.5, contour[0][1] + 0.5)
            for x, y in contour[1:]:
                path.lineTo(x + 0.5, y + 0.5)
            path.close()
        v = poly.get("intensity", 255)
        canvas.drawPath(path, skia.Paint(AntiAlias=True, Color=skia.ColorSetRGB(v, v, v)))
    surface.makeImageSnapshot().save(out, skia.kPNG)


if __name__ == "__main__":
    peer, source, out = sys.argv[1:]
    with open(source) as f:
        scene = json.load(f)
    {"agg": agg, "skia": skia}[peer](scene, out)
