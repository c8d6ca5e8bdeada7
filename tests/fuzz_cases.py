"""The case generator of the fuzz suite (tests/test_fuzz.py runs the cases and judges them).

A case is one `edgeaa` command line with the files it reads, built by a seeded generator per
command that draws every option of the command's `--help` in good and hostile forms. The
generator knows when it made the input invalid: each hostile form is listed below with the
reason it is invalid (the command must then exit 2 before any work) or with None when either
answer is right (it must then only run cleanly or refuse in one line). `quick=True` (the
default test run) keeps each case to a fraction of a second: the commands that take seconds
(verilog, synth, plot, bench, stress, a stress-sized verify) are generated only in forms that
must fail at parse time.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

CASE_SECONDS = 30.0  # a case past this is a hang (the slowest valid cases take a few s)
FAST_SECONDS = 4.0  # an invalid input is refused at once: past this it started the work
MEMORY = 1 << 30  # bytes a case may add to the worker's data (heap and anonymous maps)

# -- hostile values: (form, text made from a good value v, why it is invalid or None) -------

ARABIC_INDIC = str.maketrans("0123456789", "٠١٢٣٤٥٦٧٨٩")
FULL_WIDTH = str.maketrans("0123456789", "０１２３４５６７８９")
INTEGER_FORMS = [
    ("empty", lambda v: "", "empty number"),
    ("decimal", lambda v: f"{v}.5", "not an integer"),
    ("exponent", lambda v: "1e3", "not an integer"),
    ("hex", lambda v: "0x10", "not an integer"),
    ("underscore", lambda v: f"1_{v}", "not an integer"),
    ("inf", lambda v: "inf", "not an integer"),
    ("nan", lambda v: "nan", "not an integer"),
    ("word", lambda v: "eight", "not an integer"),
    ("arabic-indic digits", lambda v: str(v).translate(ARABIC_INDIC), "non-ASCII digits"),
    ("full-width digits", lambda v: str(v).translate(FULL_WIDTH), "non-ASCII digits"),
    ("5000 digits", lambda v: "9" * 5000, "more than 18 digits"),
    ("plus sign", lambda v: f"+{v}", None),
    ("spaces", lambda v: f" {v} ", None),
    ("leading zero", lambda v: f"0{v}", None),
]
DECIMAL_FORMS = [
    ("inf", lambda v: "inf", "not finite"),
    ("nan", lambda v: "nan", "not finite"),
    ("1e309", lambda v: "1e309", "not finite"),
    ("fraction", lambda v: "1/3", "not a decimal"),
    ("empty", lambda v: "", "empty number"),
    ("word", lambda v: "ten", "not a decimal"),
    ("hex", lambda v: "0x10", "not a decimal"),
    ("arabic-indic digits", lambda v: str(v).translate(ARABIC_INDIC), "non-ASCII digits"),
    ("full-width digits", lambda v: str(v).translate(FULL_WIDTH), "non-ASCII digits"),
    ("61 characters", lambda v: "1" + "0" * 60, "longer than 60 characters"),
    ("exponent past 60", lambda v: "1e61", "exponent past 60"),
    ("huge zero", lambda v: "0e1000000000", None),  # documented: 0, and quick
    ("minus zero", lambda v: "-0", None),
    ("plus sign", lambda v: f"+{v}", None),
]
CHOICE_FORMS = [
    ("upper case", lambda v: v.upper(), "not one of the choices"),
    ("prefix", lambda v: v[:-1], "not one of the choices"),
    ("empty", lambda v: "", "not one of the choices"),
    ("trailing space", lambda v: v + " ", "not one of the choices"),
]
# Verilog names: keywords of Verilog and SystemVerilog are refused, '$' inside is legal Verilog.
KEYWORDS = ["always", "wire", "logic", "module", "begin", "end", "reg", "input", "assign",
            "initial", "int", "bit", "class", "edge", "endmodule"]  # fmt: skip
NAMES = [
    ("plain", "my_core", None), ("long", "a" + "b" * 63, None), ("underscore", "_", None),
    ("dollar inside", "core$1", None), ("digit first", "1x", "not an identifier"),
    ("dollar first", "$core", "not an identifier"), ("empty", "", "not an identifier"),
    ("dash", "a-b", "not an identifier"), ("non-ASCII", "kérnel", "not an identifier"),
    ("65 characters", "a" * 65, "longer than 64"), ("newline", "a\nb", "not an identifier"),
    ("space", "a b", "not an identifier"),
]  # fmt: skip
TILES = [("16x16", None), ("32x16", None), ("64x32", None), ("16x32", None)]
BAD_TILES = [
    ("", "empty tile"), ("x32", "no width"), ("64x", "no height"), ("48x32", "not a power of 2"),
    ("0x0", "empty tile"), ("64X32", None), ("64x32x2", "not WIDTHxHEIGHT"),
    ("-16x16", "negative"), ("16384x16384", "tile too large"), ("65536x65536", "tile too large"),
    ("٦٤x٣٢", "non-ASCII digits"), ("６４x３２", "non-ASCII digits"), ("64 x 32", "spaces"),
]  # fmt: skip
BAD_OUTPUTS = [
    ("wrong format", "out.gif", "unsupported format"),
    ("missing folder", "no/such/out{}", "folder does not exist"),
    ("a folder", "dir{}", "a directory"),
    ("empty name", "", "empty output name"),
    ("/dev/full", "/dev/full", "unsupported format"),
]
ODD_OUTPUTS = ["out{}", "out{}", "sub/out{}", "out\nnewline{}", "out\udcff{}", "Out{}".upper()]
LIST_FORMS = [  # --widths, --intensities
    ("empty list", "", "empty list"), ("a comma", ",", "empty list"), ("word", "x", "not a list"),
    ("arabic-indic digits", "٤", "non-ASCII digits"), ("5000 digits", "9" * 5000, "too long"),
    ("empty item", "4,,8", None), ("repeated", "4,4", None), ("spaces", " 4, 8", None),
]  # fmt: skip


@dataclass
class Case:
    index: int
    argv: list[str]
    files: dict[str, bytes] = field(default_factory=dict)  # written before the run
    folders: list[str] = field(default_factory=list)  # made before the run
    invalid: list[str] = field(default_factory=list)  # why it must exit 2 (empty: valid)
    outputs: list[str] = field(default_factory=list)  # files or folders it may write
    seconds: float = CASE_SECONDS
    long_ok: bool = False  # legitimately long: running past `seconds` is no failure
    memory: int = MEMORY
    before: list[str] | None = None  # a command run first (it writes a record to damage)
    appends: dict[str, bytes] = field(default_factory=dict)  # added to files after `before`
    env: dict[str, str] = field(default_factory=dict)


class Draft:
    """A case being built: the argv, and the reasons it is invalid as they are added."""

    def __init__(self, rng: random.Random, index: int, *words: str):
        self.rng = rng
        self.case = Case(index, list(words))
        self.options: list[int] = []  # positions of option names (for abbreviation)

    def chance(self, p: float) -> bool:
        return self.rng.random() < p

    def add(self, *words: str) -> None:
        if words and words[0].startswith("--"):
            self.options.append(len(self.case.argv))
        self.case.argv += words

    def bad(self, why: str | None) -> None:
        if why is not None:
            self.case.invalid.append(why)

    def integer(self, name: str, lo: int, hi: int | None, typical, hostile=0.2) -> None:
        """An integer option: a typical value, out of [lo, hi], or a hostile form."""
        value = self.rng.choice(typical)
        if self.chance(hostile):
            if hi is not None and self.chance(0.3):
                self.add(name, str(self.rng.choice([lo - 1, hi + 1])))
                return self.bad(f"{name} out of [{lo}, {hi}]")
            form, make, why = self.rng.choice(INTEGER_FORMS)
            self.add(name, make(value))
            return self.bad(why and f"{name}: {form}")
        self.add(name, str(value))

    def choice(self, name: str, choices, hostile=0.15) -> str:
        value = self.rng.choice(choices)
        if self.chance(hostile):
            form, make, why = self.rng.choice(CHOICE_FORMS)
            self.add(name, make(value))
            self.bad(f"{name}: {form}")
            return ""
        self.add(name, value)
        return value

    def output(self, suffixes: tuple[str, ...], p=0.6, bad=0.25) -> None:
        """-o: a good name (maybe one that exists, maybe odd bytes), a bad one, or none."""
        if not self.chance(p):
            return
        suffix = self.rng.choice(suffixes)
        if self.chance(bad):
            form, pattern, why = self.rng.choice(BAD_OUTPUTS)
            name = pattern.format(suffix)
            if form == "a folder":
                self.case.folders.append(name)
            self.add("-o", name)
            return self.bad(f"-o {form}")
        name = self.rng.choice(ODD_OUTPUTS).format(suffix)
        if name.startswith("sub/"):
            self.case.folders.append("sub")
        if self.chance(0.2):
            self.case.files[name] = b"the previous file"
        self.add("-o", name)
        self.case.outputs.append(name)

    def config(self, p=0.1) -> bool:
        """The shared configuration options, each with probability p; whether any was given."""
        before = len(self.case.argv)
        for name, lo, hi, typical in (
            ("--coord-bits", 2, 16, [6, 8, 11, 16]),
            ("--subpixel-bits", 0, 8, [0, 2, 4, 8]),
            ("--intensity-bits", 1, 16, [1, 8, 10, 16]),
            ("--frac-bits", 0, None, [6, 20, 48]),
        ):
            if self.chance(p):
                self.integer(name, lo, hi, typical)
        if self.chance(p):
            self.choice("--mode", ["pw", "paper", "seg2", "seg4"])
        if self.chance(p):
            self.choice("--accumulator", ["exact", "truncated"])
        return len(self.case.argv) > before


# -- mutations of any command line -----------------------------------------------------------


def mutate_argv(d: Draft, value_options: list[str]) -> None:
    """One mutation that every command must refuse: an abbreviated, unknown, repeated or
    unfinished option."""
    kind = d.rng.randrange(4)
    argv = d.case.argv
    long_options = [i for i in d.options if len(argv[i]) > 5]
    if kind == 0 and long_options:  # `--js` for `--json`: abbreviations are refused
        at = d.rng.choice(long_options)
        argv[at] = argv[at][: d.rng.randint(4, len(argv[at]) - 1)]
        d.bad(f"abbreviated option {argv[at]}")
    elif kind == 1:
        d.add(d.rng.choice(["--frobnicate", "--Quiet", "-x", "--jsonn"]))
        d.bad("unknown option")
    elif kind == 2 and value_options:  # a value option given twice
        name = d.rng.choice(value_options)
        d.add(name, "1")
        d.add(name, "2")
        d.bad(f"{name} given twice")
    else:
        d.add(d.rng.choice(value_options or ["--frobnicate"]))  # no value after it
        d.bad("option without its value")


def require_invalid(d: Draft, fallbacks: list[tuple[list[str], str]]) -> None:
    """Slow commands in a quick case: add a bad option unless one is there already."""
    if not d.case.invalid:
        words, why = d.rng.choice(fallbacks)
        d.add(*words)
        d.bad(why)
    d.case.seconds = FAST_SECONDS


def finish(d: Draft) -> Case:
    case = d.case
    if case.invalid:
        case.seconds = min(case.seconds, FAST_SECONDS)
        case.long_ok = False
    return case


# -- the commands ----------------------------------------------------------------------------


def edge_case(d: Draft, quick: bool) -> None:
    coordinates = []
    for _ in range(d.rng.choice([4] * 12 + [3, 5])):
        value = d.rng.choice([d.rng.randint(0, 100), d.rng.randint(0, 1600) / 16, 2047.9375])
        if d.chance(0.08):
            form, make, why = d.rng.choice(DECIMAL_FORMS)
            value = make(value)
            d.bad(why and f"coordinate: {form}")
        elif d.chance(0.03):
            value = d.rng.choice(["-1", "65536"])
            d.bad("coordinate out of range")
        coordinates.append(str(value))
    if len(coordinates) != 4:
        d.bad(f"{len(coordinates)} coordinates")
    elif d.chance(0.03):
        coordinates[2:] = coordinates[:2]
        d.bad("zero-length edge")
    d.add(*coordinates)
    if d.chance(0.2):
        d.choice("--inside", ["left", "right"])
    d.config()  # first: the intensities' range follows --intensity-bits
    top = _full_scale(d.case.argv)
    for name in ("--i-in", "--i-out"):
        if d.chance(0.1):
            d.integer(name, 0, top, [0, (top + 1) // 2, top])
    if d.chance(0.1):
        d.add("--clip", *(d.rng.choice(["0", "5", "100"]) for _ in range(4)))
        if d.chance(0.2):
            d.case.argv[-1] = "9" * 50
            d.bad("clip of 50 digits")
    if d.chance(0.3):
        d.add("--json")
    if d.chance(0.1):
        mutate_argv(d, ["--inside", "--i-in", "--i-out", "--mode"])


def _full_scale(argv: list[str]) -> int:
    """The largest intensity of the --intensity-bits in `argv` (8 bits unless a valid one is
    given: an invalid one makes the case bad anyway)."""
    if "--intensity-bits" in argv[:-1]:
        value = argv[argv.index("--intensity-bits") + 1]
        if value.isascii() and value.isdigit() and len(value) <= 2 and 1 <= int(value) <= 16:
            return (1 << int(value)) - 1
    return 255


def demo_case(d: Draft, quick: bool) -> None:
    if d.chance(0.6):
        typical = [1, 2, 8, 16] if quick else [1, 8, 64, 256]
        d.integer("--spokes", 1, 4096, typical)
    if not quick and d.chance(0.02):
        d.add("--spokes", "4096")  # the documented maximum: must finish (or be refused)
    d.output((".png", ".svg", ".pdf"), p=0.2 if quick else 0.4)
    d.config(0.05)
    if d.chance(0.15):
        mutate_argv(d, ["--spokes", "--mode"])


def tile_option(d: Draft, name="--tile") -> str | None:
    if d.chance(0.7):
        tile, why = d.rng.choice(TILES)
    else:
        tile, why = d.rng.choice(BAD_TILES)
    d.add(name, tile)
    d.bad(why and f"--tile {why}")
    return tile


def top_options(d: Draft, p_top: float, p_tile: float, p_core: float) -> None:
    """``--top``, ``--tile`` and ``--core`` as verilog and synth take them (each drawn with
    its probability): a tile only with the pipeline, the deltas core only as the top."""
    top = d.choice("--top", ["core", "pipeline"]) if d.chance(p_top) else "core"
    if d.chance(p_tile):
        tile_option(d)
        if top == "core":
            d.bad("--tile with --top core")
    if d.chance(p_core):
        core = d.choice("--core", ["writes", "deltas"])
        if top == "pipeline" and core == "deltas":
            d.bad("--core deltas with --top pipeline")
    if d.chance(p_tile / 2):
        d.choice("--pipeline", ["compact", "fast"])
        if top != "pipeline":
            d.bad("--pipeline without --top pipeline")
    if d.chance(p_tile / 2):
        d.choice("--channels", ["1", "3", "4"])
        if top == "core":  # the pipeline and the peripheral take 1, 3 or 4
            d.bad("--channels with --top core")
    if d.chance(p_tile / 4):
        d.choice("--bus", ["wishbone", "axi-lite"])
        if top != "peripheral":  # the peripheral's register window
            d.bad("--bus without --top peripheral")


def verilog_case(d: Draft, quick: bool) -> None:
    top_options(d, 0.5, 0.4, 0.3)
    if d.chance(0.4):
        form, name, why = d.rng.choice(NAMES + [("keyword", k, "a keyword") for k in KEYWORDS])
        d.add("--name", name)
        d.bad(why and f"--name {form}")
    d.output((".v", ".sv"), p=0.4)
    if "-o" in d.case.argv:
        d.case.outputs += [_vlt(o) for o in d.case.outputs]
    elif d.chance(0.1):
        d.add("-o", "-")
    d.config(0.05)
    if d.chance(0.1):
        mutate_argv(d, ["--name", "--top", "--tile", "--core"])
    if not quick and d.chance(0.01):  # a large tile that elaborates for a minute today
        d.add("--tile", "256x256") if "--tile" not in d.case.argv else None
    if quick or d.chance(0.85):  # a valid one elaborates for seconds
        require_invalid(d, [(["--name", "wire"], "a keyword"), (["--tile", "x32"], "no width"),
                            (["-o", "core.txt"], "unsupported format")])  # fmt: skip


def _vlt(name: str) -> str:
    return name.rsplit(".", 1)[0] + ".vlt"


def synth_case(d: Draft, quick: bool) -> None:
    """Every synth case is invalid: synthesis takes minutes."""
    if d.chance(0.5):
        targets = d.rng.choice([["ice40"], ["ecp5"], ["ice40", "ecp5"], ["ice40", "ice40"],
                                ["xc7"], ["ecp5", "ecp5", "ice40"]])  # fmt: skip
        d.add("--target", *targets)
        if len(set(targets)) < len(targets):
            d.bad("--target repeats a family")
        if "xc7" in targets:
            d.bad("--target xc7")
    if d.chance(0.3):
        d.integer("--seed", 0, 2**31 - 1, [0, 1, 7])
    top_options(d, 0.4, 0.3, 0.2)
    if d.chance(0.2):
        d.integer("--setup-units", 1, 16, [1, 2, 16])
    d.config(0.05)
    if d.chance(0.2):
        mutate_argv(d, ["--seed", "--top", "--tile", "--setup-units"])
    fallbacks = [
        (["--target", "ice40", "ice40"], "--target repeats a family"),
        (["--seed", "-1"], "--seed out of range"),
        (["--top", "core", "--tile", "16x16"], "--tile with --top core"),
    ]
    require_invalid(d, fallbacks)


BOARD_OUTPUTS = [  # (-o folder, files made first, why it is refused)
    ("", {}, "-o names no folder"),
    ("taken", {"taken": b"a file"}, "-o is a file"),
    ("no/such/folder", {}, "-o's parent does not exist"),
]


def board_case(d: Draft, quick: bool) -> None:
    """Every board case is invalid: a bitstream takes ten minutes and a simulation builds the
    board in Verilator for minutes."""
    if d.chance(0.3):
        d.choice("--board", ["ulx3s-85f"], hostile=0.6)
    if d.chance(0.5):
        d.add("--simulate")
    if d.chance(0.3):
        d.add("--json")
    if d.chance(0.8):
        folder, files, why = d.rng.choice(BOARD_OUTPUTS)
        d.add(d.rng.choice(["-o", "--output"]), folder)
        d.case.files.update(files)
        d.bad(why)
    if d.chance(0.2):
        mutate_argv(d, ["--board", "--output"])
    require_invalid(d, [(["-o", ""], "-o names no folder")])


PLOT_DEFAULTS = {
    "error-vs-slope": "error_vs_slope.png", "aa-methods": "aa_methods.png", "taa": "aa_taa.png"
}  # fmt: skip


def plot_case(d: Draft, quick: bool) -> None:
    figure = d.rng.choice(["error-vs-slope", "aa-methods", "taa", "nonsense", ""])
    d.add(figure)
    if figure in ("nonsense", ""):
        return d.bad("unknown figure")
    d.output((".png", ".svg", ".pdf"), p=0.5)
    if not d.case.outputs and "-o" not in d.case.argv:
        d.case.outputs.append(PLOT_DEFAULTS[figure])  # plot's own default: asked for
    if figure == "error-vs-slope":
        _slope_options(d)
        values = ["--step", "--length", "--offsets", "--mode"]
    elif figure == "aa-methods":
        d.integer("--edges", 1, 100_000, [1, 2])
        if d.chance(0.3):
            d.integer("--seed", 0, 2**32 - 1, [0, 1])
        values = ["--edges", "--seed"]
        d.case.seconds = 120.0
    else:
        d.integer("--frames", 2, 256, [2, 3])
        if d.chance(0.4):
            _decimal(d, "--step", 0, 45, [0.5, 10])
        values = ["--frames", "--step"]
        d.case.seconds = 90.0
    d.add("--quiet")
    if d.chance(0.15):
        mutate_argv(d, values)
    if quick or d.chance(0.8 if figure == "aa-methods" else 0.6):  # valid: 2 to 10 s
        require_invalid(d, [(["--frobnicate"], "unknown option")])


def _decimal(d: Draft, name: str, lo: float, hi: float, typical) -> None:
    value = d.rng.choice(typical)
    if d.chance(0.25):
        form, make, why = d.rng.choice(DECIMAL_FORMS + [("above range", lambda v: hi + 1, "x")])
        d.add(name, str(make(value)))
        return d.bad(why and f"{name}: {form}")
    d.add(name, str(value))


def _slope_options(d: Draft) -> None:
    _decimal(d, "--step", 0.01, 45, [30, 45])
    d.integer("--offsets", 1, 1024, [1, 2])
    if d.chance(0.4):
        d.integer("--length", 4, 1 << 16, [8, 16, 64])
    d.add("--no-post", "--no-peers")
    d.config(0.15)
    d.case.seconds = 60.0


def bench_case(d: Draft, quick: bool) -> None:
    quick_flag = d.chance(0.8)
    if quick_flag:
        d.add("--quick")
    for flag in ("--no-synth", "--no-lines"):
        if d.chance(0.5):
            d.add(flag)
    d.integer("--edges", 1, 100_000, [2, 5])
    d.integer("--repeats", 1, 100, [1])
    if d.chance(0.3):
        d.integer("--seed", 0, 2**32 - 1, [0, 1])
    d.output((".png", ".svg", ".pdf"), p=0.7)
    if d.chance(0.1):
        d.integer("--coord-bits", 6, 16, [6, 11])  # the command needs at least 6
    if "--coord-bits" not in d.case.argv:
        d.config(0.1)  # a --coord-bits below 6 from here may be refused: no reason given
    d.add("--quiet")
    d.case.seconds = 60.0
    if d.chance(0.15):
        mutate_argv(d, ["--edges", "--repeats", "--seed"])
    if quick or not quick_flag or d.chance(0.75):
        require_invalid(d, [(["--edges", "0"], "--edges out of range"),
                            (["--coord-bits", "5"], "--coord-bits below 6")])  # fmt: skip


def stress_case(d: Draft, quick: bool) -> None:
    d.add("--quick", "--skip-bounds", "--quiet")
    lists = {}
    for name, good in (("--widths", ["2,4", "2", "4"]), ("--intensities", ["4", "4,8"])):
        if d.chance(0.3):
            form, text, why = d.rng.choice(LIST_FORMS)
            d.add(name, text)
            d.bad(why and f"{name}: {form}")
            lists[name] = None
        else:
            lists[name] = d.rng.choice(good)
            d.add(name, lists[name])
    if d.chance(0.3):
        d.integer("--subpixel-bits", 0, 8, [0, 4])
    if d.chance(0.3):
        d.integer("--plot-coord-bits", 2, 16, [4, 6])
    plot_i = d.rng.choice([4, 4, 8, 3])
    d.add("--plot-intensity-bits", str(plot_i))
    if lists["--intensities"] and str(plot_i) not in lists["--intensities"].split(","):
        d.bad("--plot-intensity-bits not in --intensities")
    d.output((".png", ".svg", ".pdf"), p=0.7)
    d.case.seconds = 90.0
    if d.chance(0.15):
        mutate_argv(d, ["--widths", "--intensities", "--subpixel-bits"])
    if quick or d.chance(0.8):  # a valid one takes 6 s
        require_invalid(d, [(["--widths", ""], "--widths: empty list"),
                            (["--intensities", "0"], "--intensities out of range")])  # fmt: skip


# -- verify and render -----------------------------------------------------------------------


def _nested(depth: int) -> bytes:
    return b"[" * depth + b"]" * depth


RUN_RECORDS = [  # run.json written before the run: every one is damaged
    (b"[]", "run.json is a list"), (b'"a run"', "run.json is a string"),
    (b"null", "run.json is null"), (b"7", "run.json is a number"),
    (_nested(100_000), "run.json nested 100,000 deep"), (_nested(50), "run.json nested"),
    (b'{"format": 1', "run.json cut short"), (b"\xff\xfe{}", "run.json is not UTF-8"),
    (b"{}", "run.json of another run"), (b'{"format": [[[]]]}', "run.json of another run"),
]  # fmt: skip
SHARD_LINES = [  # lines added to the shards.jsonl of a finished run
    (b"[]\n", "a shard record is a list"), (b"null\n", "a shard record is null"),
    (b'"x"\n', "a shard record is a string"),
    (b'{"index": 0}\n', "a shard record without fields"),
    (b'{"index": "0"}\n', "a shard index is a string"),
    (b'{"index": 99}\n', "a shard index past the run"),
    (_nested(100_000) + b"\n", "a shard record nested 100,000 deep"),
    (b'{"index": 0, "se', None),  # cut short by an interrupt: dropped by design
]  # fmt: skip


def verify_case(d: Draft, quick: bool) -> None:
    if d.chance(0.1):
        return _scenes_case(d, quick)
    edges = d.rng.choice([1, 2, 4, 8])
    d.integer("--edges", 1, 10**12, [edges], hostile=0.15)
    if d.chance(0.4):
        d.integer("--shards", 1, edges, [1, min(2, edges)], hostile=0.2)
    if d.chance(0.15):
        d.integer("--shard-seed", 0, 2**64 - 1, [0, 12345], hostile=0.2)
        if "--seed" in d.case.argv or "--shards" in d.case.argv or d.chance(0.3):
            d.add("--seed", "3")
            d.bad("--shard-seed with --seed")
    elif d.chance(0.3):
        d.integer("--seed", 0, None, [1, 2, 99])
    workers = d.rng.choice(["0"] * 9 + ["1"])
    if d.chance(0.1):
        d.integer("--workers", 0, 256, [0], hostile=0.6)
    else:
        d.add("--workers", workers)
    if d.chance(0.05) and d.case.argv[-2:] == ["--workers", "0"]:  # a real cluster is slow
        d.add("--cluster", d.rng.choice(["local", "tcp://127.0.0.1:1"]))
        d.bad("--cluster with --workers 0")
    config = d.config(0.06)
    # Verilator builds (or checks the cache of) the core: seconds. Another config: a new build.
    engines = ["amaranth"] if config or (quick and d.chance(0.8)) else ["amaranth", "verilator"]
    d.choice("--engine", engines, hostile=0.05)
    for flag in ("--json", "--quiet"):
        if d.chance(0.5):
            d.add(flag)
    if d.chance(0.5):
        _record(d)
    if d.chance(0.1):
        mutate_argv(d, ["--edges", "--seed", "--shards", "--workers", "--engine", "--out"])
    if not quick and not d.case.invalid and d.chance(0.01):
        _huge_verify(d)


def _scenes_case(d: Draft, quick: bool) -> None:
    """--scenes: random scenes through the Verilated pipeline. A valid run builds (or checks the
    cache of) the pipeline: seconds, so the quick campaign makes only the refused forms."""
    d.integer("--scenes", 1, 10**9, [1, 2], hostile=0.3)
    d.add("--workers", "0")
    kind = d.rng.randrange(4)
    if kind == 0:
        d.add("--edges", "2")
        d.bad("--scenes with --edges")
    elif kind == 1:
        d.add("--engine", "amaranth")
        d.bad("--scenes with --engine amaranth")
    elif kind == 2 or quick:
        d.add("--shards", d.rng.choice(["0", "3"]))  # more shards than scenes, or none
        d.bad("--shards out of [1, --scenes]")
    if d.chance(0.3):
        d.add("--json")


def _record(d: Draft) -> None:
    """--out DIR: a fresh folder, a file, a damaged run.json, or damaged shard lines."""
    d.add("--out", "rec")
    d.case.outputs.append("rec/")
    kind = d.rng.randrange(5)
    if kind == 1:
        d.case.files["rec"] = b"a file, not a folder"
        d.bad("--out is a file")
    elif kind == 2:
        text, why = d.rng.choice(RUN_RECORDS)
        d.case.files["rec/run.json"] = text
        d.bad(why)
    elif kind >= 3 and not d.case.invalid:  # a finished run, then its records damaged
        d.case.before = list(d.case.argv)
        if kind == 3:
            line, why = d.rng.choice(SHARD_LINES)
            d.case.appends["rec/shards.jsonl"] = line
            d.bad(why)
        else:  # the same folder, another run
            at = d.case.argv.index("--edges") + 1
            d.case.argv[at] = str(int(d.case.argv[at]) + 1)
            d.bad("--out holds another run")


def _huge_verify(d: Draft) -> None:
    """10^8 edges in one shard: a long run, but its memory must stay bounded."""
    argv = d.case.argv
    d.case.argv = ["verify", "--edges", "100000000", "--shards", "1", "--workers", "0"]
    d.case.argv += ["--engine", "amaranth", "--quiet"] + (
        ["--out", "rec"] if "rec/" in argv else []
    )
    d.case.long_ok, d.case.seconds, d.case.memory = True, 25.0, 600 << 20


TOP_LEVEL = [
    ([], "no command"), (["nonsense"], "unknown command"), (["--help"], None),
    (["rend"], "abbreviated command"), (["--version"], "unknown option"),
    (["", "render"], "empty command"),
]  # fmt: skip


def top_level_case(d: Draft, quick: bool) -> None:
    words, why = d.rng.choice(TOP_LEVEL)
    d.add(*words)
    d.bad(why)


def describe(case: Case) -> str:
    """The case in a line: the argv (ASCII-escaped), the files, why it is invalid."""
    files = {name: len(data) for name, data in case.files.items()}
    why = "; ".join(case.invalid) or "valid"
    return (
        f"argv {ascii(case.argv)}; files {ascii(files)}; {why}"
        + (f"; first {ascii(case.before)}" if case.before else "")
        + (f"; env {case.env}" if case.env else "")
    )
