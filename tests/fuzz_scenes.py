"""Scene files for the fuzz suite: a small valid scene, then mutations of its data (hostile
numbers, wrong types, unknown keys, huge sizes, curves past the limits) or of its text (NaN,
1e400, duplicate keys, deep nesting, bytes that are not UTF-8, truncation).

`scene_file` returns the bytes, the reasons the scene is invalid (docs/scenes.md, "Errors and
limits": a scene with one of them must be refused) and the image size it asks for. A mutation
whose answer depends on the rest of the scene (a -1 in place of a coordinate) adds no reason:
either answer is right, as long as it is a clean one.
"""

from __future__ import annotations

import copy
import json
import random

from fuzz_cases import Draft, mutate_argv, tile_option

HOSTILE_JSON_VALUES = [
    None, True, [], {}, [1, 2], "12", -1, 0, 1e300, -1e300, 10**30, 1.5, 2**63,
    [[0, 0], [1, 1]], "M 0 0 L 1 1 Z", {"points": []},
]  # fmt: skip
# Polygons added to a scene: (polygon, why it is invalid or None).
ADDED_POLYGONS = [
    ({"path": "M 0 0 C 1e300 0 0 1e300 10 10 Z"}, "control point past +-1,048,576 px"),
    ({"path": "M 0 0 L 10 0 L 10 10 L"}, "path command without its numbers"),
    ({"path": "M 0 0 L 10 0 L 10 10 C 1 2"}, "path command without its numbers"),
    ({"path": "M 0 0 L 10 0 L 10 10 Q"}, "path command without its numbers"),
    ({"path": "M 0 0 L 10 0 L 10 10 m"}, None),
    ({"path": "M 0 0 L 10 0 L 10 10 A 1 1 0 0 0 5 5 Z"}, None),
    ({"path": "M 0 0 A 1 1 0 3 0 5 5 Z"}, "an arc flag of 3"),
    ({"path": "M 0 0 h 9 v 9", "stroke": {"width": 2, "dash": [1e-9]}}, "too many dashes"),
    ({"path": "M 0 0 h 9", "stroke": {"width": 2, "join": "sharp"}}, "unknown join"),
    ({"points": [[0, 0], [9, 0], [0, 9]], "color": "#zz0000"}, "a bad colour"),
    ({"points": [[0, 0], [9, 0], [0, 9]], "transform": [1e9, 0, 0, 1, 0, 0]}, "transform 1e9"),
    (
        {
            "path": "M 2 2 a 4 6 30 1 1 9 9",
            "stroke": {"width": 1.5, "cap": "round"},
            "color": [0.2, 0.4, 0.6, 0.5],
            "transform": [1, 0.2, 0, 1, 3, 0],
        },
        None,
    ),
    ({"points": [[0, 0], [0, 0], [0, 0]]}, None),
    ({"points": [[0, 0], [4, 4], [0, 4], [4, 0]], "fill_rule": ["evenodd"]}, "fill_rule a list"),
    ({"contours": [[[0, 0], [8, 0], [8, 8]], [[0, 0], [8, 0], [8, 8]]]}, None),
    ({"points": [[0, 0], [1e6, 0], [0, 1e6]]}, None),
    ({"path": "M 0 0 " + "l 1 0 " * 20000 + "z"}, "20,000 edges in one polygon"),
]
LITERALS = [  # a number of the text replaced by: (literal, why)
    (b"NaN", "NaN"), (b"Infinity", "Infinity"), (b"-Infinity", "-Infinity"),
    (b"1e400", "1e400"), (b"1" * 5000, "a number of 5000 digits"),
    (b"0e1000000000", None), (b"-0.0", None),
]  # fmt: skip
FILL_RULES = [("nonzero", None), ("evenodd", None), ("non-zero", None), ("even-odd", None),
              ("NonZero", "unknown fill_rule"), ("", "unknown fill_rule")]  # fmt: skip


def _coordinate(rng: random.Random) -> float | int:
    value = rng.choice([rng.randint(-8, 72), rng.uniform(-8, 72), rng.randint(0, 64) / 16])
    return round(value, rng.choice([0, 2, 4, 9])) if isinstance(value, float) else value


def _path(rng: random.Random) -> str:
    parts = [f"M {_coordinate(rng)} {_coordinate(rng)}"]
    arity = {"L": 2, "H": 1, "V": 1, "C": 6, "S": 4, "Q": 4, "T": 2, "Z": 0}
    for _ in range(rng.randint(1, 8)):
        command = rng.choice(list(arity))
        command = command.lower() if rng.random() < 0.4 else command
        numbers = [str(_coordinate(rng)) for _ in range(arity[command.upper()])]
        parts.append(" ".join([command, *numbers]))
    separator = rng.choice([" ", ",", "\f", "\t", "\n", "  "])
    return separator.join(parts)


def _points(rng: random.Random, lo: int, hi: int) -> list:
    return [[_coordinate(rng), _coordinate(rng)] for _ in range(rng.randint(lo, hi))]


def _polygon(rng: random.Random, whys: list) -> dict:
    shape = rng.choice(["points", "contours", "path"])
    if shape == "points":
        item = {"points": _points(rng, 3, 7)}
    elif shape == "contours":
        item = {"contours": [_points(rng, 3, 6) for _ in range(rng.randint(1, 3))]}
    else:
        item = {"path": _path(rng)}
    if rng.random() < 0.7:
        item["intensity"] = rng.randint(0, 255)
    elif rng.random() < 0.4:
        item["color"] = rng.choice(["#0a0", "#123456", "#12345678", [0.1, 0.5, 1], [1, 0, 0, 0.3]])
    if rng.random() < 0.15:
        item["transform"] = [rng.uniform(-2, 2) for _ in range(4)] + [_coordinate(rng)] * 2
    if rng.random() < 0.2:
        item["stroke"] = {"width": rng.choice([0.25, 1, 3]), "cap": rng.choice(["butt", "round"]),
                          "join": rng.choice(["miter", "round", "bevel"])}  # fmt: skip
        if rng.random() < 0.3:
            item["stroke"]["dash"] = [rng.choice([0, 1, 2.5]), rng.choice([1, 3])]
    elif rng.random() < 0.4:
        item["fill_rule"], why = rng.choice(FILL_RULES)
        whys += [why] if why else []
    return item


def scene_data(rng: random.Random, whys: list) -> dict:
    data = {
        "width": rng.randint(1, 64),
        "height": rng.randint(1, 64),
        "polygons": [_polygon(rng, whys) for _ in range(rng.randint(0, 4))],
    }
    if rng.random() < 0.5:
        data["background"] = rng.randint(0, 255)
    if rng.random() < 0.3:
        data["tolerance"] = rng.choice([1 / 16, 0.5, 0.01, 1 / 1024])
    return data


def _leaves(data):
    """Every (container, key) in the JSON data, so a mutation can replace any value."""
    items = data.items() if isinstance(data, dict) else enumerate(data)
    for key, value in items:
        yield data, key
        if isinstance(value, dict | list):
            yield from _leaves(value)


def mutate_data(rng: random.Random, data: dict) -> str | None:
    """Mutate the scene's data in place; return why it is now invalid (None: it may not be)."""
    kind = rng.randrange(4)
    places = list(_leaves(data))
    if kind == 0 and places:  # a value of the wrong type or out of every range
        container, key = rng.choice(places)
        container[key] = copy.deepcopy(rng.choice(HOSTILE_JSON_VALUES))  # never shared
        return None
    if kind == 1:  # huge sizes, tiny tolerance
        key, value, why = rng.choice(
            [("width", 65536, None), ("height", 1 << 20, None),
             ("tolerance", 1e-300, "tolerance below 1/1024"), ("tolerance", 0.0, "tolerance 0")]
        )  # fmt: skip
        data[key] = value
        return why
    if kind == 2:
        polygons = data.get("polygons")
        data["polygons"] = polygons = polygons if isinstance(polygons, list) else []
        polygon, why = rng.choice(ADDED_POLYGONS)
        polygons.append(copy.deepcopy(polygon))
        return why
    if places:  # an unknown key
        container, _ = rng.choice(places)
        if isinstance(container, dict):
            container[rng.choice(["widht", "colour", "Points"])] = 1
            return "an unknown key"
    return None


def mutate_text(rng: random.Random, text: bytes) -> tuple[bytes, str | None]:
    """The text mutated; why it is now invalid (None: it may not be)."""
    kind = rng.randrange(8)
    if kind == 0:
        if b'"width": ' not in text:
            return text, None
        return text.replace(b'"width": ', b'"width": 3, "width": ', 1), "a duplicate key"
    if kind == 1:
        depth = rng.choice([100, 5000, 100000])
        return b"[" * depth + b"]" * depth, "nested lists, not a scene"
    if kind == 2:
        return text[: rng.randrange(max(1, len(text)))], "cut short"
    if kind == 3:
        at = rng.randrange(max(1, len(text)))
        byte = rng.choice([b"\xff", b"\xc3", b"\x00", b"\xef\xbb\xbf"])
        why = None if (at == 0 and byte == b"\xef\xbb\xbf") else f"the byte(s) {byte!r} inside"
        return text[:at] + byte + text[at:], why
    literal, why = rng.choice(LITERALS)
    # Where a number starts: not its fraction (3.111... of 5,000 digits is a fine number) and
    # not its exponent (1e-300 made 1e+300 would no longer be the value a data mutation chose).
    digits = [i for i, c in enumerate(text) if 48 <= c <= 57 and _starts_number(text, i)]
    if not digits:
        return text, None
    at = rng.choice(digits)
    end = at
    while end < len(text) and (48 <= text[end] <= 57 or text[end] in b".-eE+"):
        end += 1
    return text[:at] + literal + text[end:], why


SET_VALUES = {"tolerance below 1/1024": ("tolerance", 1e-300), "tolerance 0": ("tolerance", 0.0)}


def _starts_number(text: bytes, i: int) -> bool:
    """Whether the digit at `i` starts a number: not after a digit or a point (a fraction),
    nor after an exponent's `e`, `e+` or `e-`."""
    before = text[max(0, i - 2) : i].decode("latin-1")
    return not (before[-1:] in "0123456789." or before[-1:] in "eE" or before in "e+e-E+E-")


def scene_file(rng: random.Random) -> tuple[bytes, list[str], tuple[int, int]]:
    """A scene file's bytes, why it is invalid (empty: maybe valid) and its width, height."""
    whys: list[str] = []
    data = scene_data(rng, whys)
    for _ in range(rng.choice([0, 0, 0, 1, 1, 2, 3])):
        why = mutate_data(rng, data)
        whys += [why] if why else []
    # A later mutation may have replaced a value an earlier one made invalid.
    whys = [
        w for w in whys if w not in SET_VALUES or data.get(SET_VALUES[w][0]) == SET_VALUES[w][1]
    ]
    text = json.dumps(data, indent=rng.choice([None, 1])).encode()
    if rng.random() < 0.25:
        text, why = mutate_text(rng, text)
        whys += [why] if why else []
    size = tuple(v if isinstance(v, int) else 0 for v in (data["width"], data["height"]))
    return text, whys, size


# -- edgeaa render ---------------------------------------------------------------------------


# -- SVG files -------------------------------------------------------------------------------

SVG_SHAPES = [  # valid elements of the subset
    '<rect x="{a}" y="{b}" width="{c}" height="{d}" rx="{e}"/>',
    '<circle cx="{a}" cy="{b}" r="{c}"/>',
    '<ellipse cx="{a}" cy="{b}" rx="{c}" ry="{d}" transform="rotate({e})"/>',
    '<line x1="{a}" y1="{b}" x2="{c}" y2="{d}" stroke="red" stroke-width="{e}"/>',
    '<polyline points="{a},{b} {c},{d} {e},{a}" fill="none" stroke="#0a0" '
    'stroke-linejoin="bevel"/>',
    '<polygon points="{a},{b} {c},{d} {e},{a}" fill-rule="evenodd" fill-opacity="0.5"/>',
    '<path d="M{a} {b} A {c} {d} {e} 1 0 {b} {a} Z" fill="rgb(10,20,30)"/>',
    '<path d="M{a} {b} q {c} {d} {e} 3 t 4 5 s 1 2 3 4 z M12 5v1" opacity="0.3"/>',
    '<path d="M{a} {b} L {c} {d} L {e} 1" fill="none" stroke="navy" stroke-linecap="round" '
    'stroke-dasharray="{c} 2" stroke-dashoffset="{e}"/>',
    '<g transform="skewX({e}) scale(0.5)" fill="currentColor" color="gold">'
    '<rect width="{c}" height="{d}"/></g>',
    '<use href="#d" x="{a}" y="{b}"/>',
]
# (element, why it must be refused; None: either answer, cleanly). "subset: ..." reasons are
# the elements outside the subset, which --lenient skips with a warning.
SVG_ODD = [
    ("<text>hi</text>", "subset: <text>"),
    ('<image href="x.png" width="4" height="4"/>', "subset: <image>"),
    ('<rect width="4" height="4" fill="url(#g)"/>', "subset: gradient paint"),
    ('<rect width="4" height="4" filter="url(#f)"/>', "subset: filter"),
    ('<circle r="3" clip-path="url(#c)"/>', "subset: clip-path"),
    ('<mask id="m"/>', "subset: <mask>"),
    ('<path d="M0 0 L 1e300 0 L 0 9 Z"/>', "svg coordinate past the limit"),
    ('<path d="M0 0 A 1e6 1e6 0 1 1 0 1e-9"/>', None), ('<circle r="nan"/>', None),
    ('<rect width="-4" height="4"/>', None), ('<path d="M 0 0 L 5 x 7 Z"/>', None),
    ('<g transform="scale(1e12)"><circle r="3"/></g>', None),
    ('<path d="M0 0 H 60" stroke="red" stroke-dasharray="0.0001"/>', "svg too many dashes"),
    ('<path d="M0 0 H 60" stroke="red" stroke-dasharray="1 -1"/>', "svg negative dash"),
    ('<path d="M0 0 H 60" stroke="red" stroke-linejoin="sharp"/>', "svg unknown linejoin"),
    ('<path d="M0 0 H 60 V 9" stroke="red" stroke-width="1e9" stroke-linejoin="round"/>', None),
    ('<rect width="4" height="4" style="fill:#zzz;stroke-miterlimit:0.5" stroke="red"/>', None),
    ('<g>' * 3000 + "</g>" * 3000, None), ('<rect width="4" height="4" opacity="1e999"/>', None),
]  # fmt: skip
SVG_ROOTS = [  # (attributes of <svg>, why it must be refused)
    ('width="48" height="32"', None), ('viewBox="0 0 24 24"', None),
    ('width="2in" height="1cm" viewBox="-4 -4 8 8" preserveAspectRatio="xMaxYMin slice"', None),
    ('width="0" height="10"', "svg of width 0"), ('width="1e9" height="1e9"', "svg of 1e18 px"),
    ('width="nan" height="4"', None), ('viewBox="0 0 0 0"', None), ("", None),
]  # fmt: skip


def svg_file(rng: random.Random) -> tuple[bytes, list[str]]:
    """An SVG file's bytes and why it is invalid (empty: maybe valid)."""
    whys: list[str] = []
    root, why = rng.choice(SVG_ROOTS) if rng.random() < 0.4 else SVG_ROOTS[rng.randrange(3)]
    whys += [why] if why else []
    parts = ['<defs><path id="d" d="M0 0h3v3z"/></defs>']
    for _ in range(rng.randint(1, 5)):
        numbers = {k: round(rng.uniform(-5, 40), rng.choice([0, 2])) for k in "abcde"}
        parts.append(rng.choice(SVG_SHAPES).format(**numbers))
    if rng.random() < 0.4:
        element, why = rng.choice(SVG_ODD)
        parts.insert(rng.randrange(len(parts) + 1), element)
        whys += [why] if why else []
    text = f'<svg xmlns="http://www.w3.org/2000/svg" {root}>{"".join(parts)}</svg>'.encode()
    kind = rng.randrange(10)
    if kind == 0:
        text, why = text[: rng.randrange(len(text))], "svg cut short"
        whys += [why]
    elif kind == 1:
        at = rng.randrange(len(text))
        text = text[:at] + rng.choice([b"\xff", b"\x00", b"<", b"&x;"]) + text[at:]
    elif kind == 2:  # entities that expand a billion times
        lol = b'<!DOCTYPE s [<!ENTITY a "aaaaaaaaaa">' + b"".join(
            b'<!ENTITY %c "%s">' % (98 + i, (b"&%c;" % (97 + i)) * 10) for i in range(8)
        )
        text = lol + b"]>" + text.replace(b"<defs>", b"<desc>&i;</desc><defs>", 1)
    return text, whys


def _svg_options(d: Draft, svg: bool) -> None:
    """--size, --scale, --lenient: with an .svg file, or refused with any other."""
    if d.chance(0.25):
        value, why = d.rng.choice(
            [
                ("64x48", None),
                ("1x1", None),
                ("0x4", "--size 0"),
                ("4", "--size without x"),
                ("9999x9999", "--size too large"),
            ]
        )
        d.add("--size", value)
        d.bad(why if svg else "--size without an .svg file")
    if d.chance(0.2):
        value, why = d.rng.choice(
            [
                ("2", None),
                ("0.25", None),
                ("0", "--scale 0"),
                ("nan", "--scale nan"),
                ("1e9", "--scale past the limit"),
            ]
        )
        d.add("--scale", value)
        d.bad(why if svg else "--scale without an .svg file")
    if "--size" in d.case.argv and "--scale" in d.case.argv:
        d.bad("--size with --scale")
    if not svg and d.chance(0.1):  # an SVG case chooses --lenient itself
        d.add("--lenient")
        d.bad("--lenient without an .svg file")


def render_case(d: Draft, quick: bool) -> None:
    if d.chance(0.25):
        return _svg_case(d, quick)
    name = "scene.json"
    if d.chance(0.05):
        name = d.rng.choice(["sc\nene.json", "sc\udcffene.json", "scène.json", "a b.json"])
    scene, whys, size = scene_file(d.rng)
    exists, given = d.chance(0.93), d.chance(0.97)
    if exists:
        d.case.files[name] = scene
    if given:  # what is wrong with the file matters only when it is read
        d.add(name)
        for why in whys if exists else ["the scene file does not exist"]:
            d.bad(why)
    render_options(d, quick, name, size)
    _svg_options(d, False)


def _svg_case(d: Draft, quick: bool) -> None:
    """An SVG file, valid or damaged, with the SVG options."""
    name = "icon.svg" if d.chance(0.9) else "ICON.SVG"
    text, whys = svg_file(d.rng)
    d.case.files[name] = text
    d.add(name)
    lenient = d.chance(0.3)
    if lenient:
        d.add("--lenient")
    render_options(d, quick, name, (0, 0))
    _svg_options(d, True)
    sized = "--size" in d.case.argv
    for why in whys:  # --lenient skips the subset's refusals; --size sets the image
        skipped = lenient and why.startswith("subset:")
        d.bad(None if skipped or (sized and why == "svg of 1e18 px") else why)
    hardware = any(word in d.case.argv for word in ("amaranth", "verilator"))
    # The hardware draws colour, alpha included; layers (group opacity) it refuses, so a
    # colour SVG on a hardware engine may go either way, cleanly.
    if d.chance(0.1):  # an SVG scene is a colour scene: linear light applies
        d.add("--linear-light")
        d.bad("--linear-light on a hardware engine" if hardware else None)
        d.bad("--linear-light with --compare" if "--compare" in d.case.argv else None)


CONFLICTS = [("--compare", "--error"), ("--compare", "--stats"), ("--compare", "--no-skip"),
             ("--stats", "--no-skip"), ("--compare", "--json")]  # fmt: skip
CROPS = [("0,0,8,8", None), ("1,2", "--crop of 2 numbers"), ("5,5,1,1", "--crop empty"),
         ("0,0," + "9" * 400, "--crop of 400 digits"), ("", "--crop empty"),
         ("0,0,٨,٨", "--crop: non-ASCII digits")]  # fmt: skip


def render_options(d: Draft, quick: bool, scene: str, size: tuple[int, int]) -> None:
    argv = d.case.argv
    if d.chance(0.04):
        d.add("--builtin", d.rng.choice(["starburst", "text", "hatch"]))
        d.case.seconds = 60.0
    if ("--builtin" in argv) == (scene in argv):
        d.bad("a scene file and --builtin, or neither")
    flags = [("--stats", 0.1), ("--no-skip", 0.1), ("--error", 0.08), ("--compare", 0.04),
             ("--quiet", 0.5), ("--json", 0.1)]  # fmt: skip
    for flag, p in flags:
        if d.chance(p):
            d.add(flag)
    for first, second in CONFLICTS:
        if first in argv and second in argv:
            d.bad(f"{first} with {second}")
    if d.chance(0.06) or ("--compare" in argv and d.chance(0.3)):
        crop, why = d.rng.choice(CROPS)
        d.add("--crop", crop)
        d.bad(why if "--compare" in argv else "--crop without --compare")
    if "--compare" in argv:
        d.case.seconds = 60.0
    config = d.config(0.08)
    _render_engine(d, quick, config, size)
    if d.chance(0.25) and "--compare" not in argv:  # -o naming the scene itself
        d.add("-o", scene)
        d.bad("-o is the input")
    else:
        d.output((".png",), p=0.85 if "--compare" in argv else 0.6)
    if "--compare" in argv and "-o" not in argv:
        d.bad("--compare without -o")
    if d.chance(0.08):
        mutate_argv(d, ["--engine", "--tile", "--crop", "--mode", "--coord-bits", "--builtin"])


def _render_engine(d: Draft, quick: bool, config: bool, size: tuple[int, int]) -> None:
    """--engine and --tile: the hardware engines only on small scenes, Verilator only in the
    configuration whose build is cached (another configuration builds for half a minute)."""
    argv = d.case.argv
    small = 0 < size[0] * size[1] <= 32 * 32 and "--builtin" not in argv
    r = d.rng.random()
    # Each Verilator case elaborates the pipeline to look up its build: 5 s; Amaranth 1 s.
    if r < 0.04 and small and (not quick or d.chance(0.5)):
        engine = "amaranth"
    elif r < 0.08 and not config and (small or d.chance(0.3)) and d.chance(0.2 if quick else 0.4):
        engine = "verilator"
    elif r < 0.14:
        engine = "spice"
    else:
        engine = "model" if d.chance(0.1) else None
    if engine is not None:
        d.add("--engine", engine)
        d.bad("--engine spice" if engine == "spice" else None)
        d.case.seconds = max(d.case.seconds, 120.0 if engine == "verilator" else 60.0)
    hardware = engine in ("amaranth", "verilator")
    if d.chance(0.5 if hardware else 0.04):
        tile_option(d)
        if not hardware:
            d.bad("--tile without a hardware engine")
        elif not quick and d.chance(0.03):
            argv[-1] = "1024x1024"  # large, accepted today: it must finish or be refused
    if d.chance(0.3 if hardware else 0.03):  # fast builds anew in Verilator: compact there
        d.choice("--pipeline", ["compact"] if engine == "verilator" else ["compact", "fast"])
        if not hardware:
            d.bad("--pipeline without a hardware engine")
    if hardware and "--compare" in argv:
        d.bad("--compare with a hardware engine")
    if hardware and "--no-skip" in argv:
        d.bad("--no-skip with a hardware engine")
    if d.chance(0.06):  # threads for the model's bands
        d.integer("--workers", 1, 64, [1, 2, 3])
        value = argv[-1].strip().lstrip("+")
        several = value.isascii() and value.isdigit() and len(value) < 4 and 1 < int(value) <= 64
        if several and (hardware or "--compare" in argv or "--no-skip" in argv):
            d.bad("--workers with a hardware engine, --compare or --no-skip")
    if engine == "verilator" and d.chance(0.1):  # the build cache is not a folder
        d.case.files["cachefile"] = b"not a folder"
        d.case.env["XDG_CACHE_HOME"] = "{folder}/cachefile"
