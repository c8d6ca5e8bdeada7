"""Seeded fuzzing of the command line and the scene parser (docs/scenes.md, "Errors and limits").

Each case is a command line (mostly `edgeaa render` on a generated scene file, also `edge` and,
with at least one bad option, the slow commands) run in-process by `edgeaa.cli.main` in a
worker process, in a fresh folder, with stdout and stderr captured. The worker is killed and
replaced when a case runs past its time limit. A case fails on:

- a traceback (any exception out of `main`), or a hang (the time limit);
- an error that is not one line starting with "edgeaa" and exit status 2;
- an input file changed (the scene, or a file that `-o` named);
- a half-written file: an output left by a failed command, a temporary file left behind, or
  an output that is not a whole PNG (Verilog: the module's last line).

Scenes start valid and small, then get up to three mutations of their data (hostile numbers,
wrong types, unknown keys) or of their text (NaN, 1e400, duplicate keys, deep nesting, bytes
that are not UTF-8, truncation). `pytest tests/test_fuzz.py` runs a bounded campaign;
`pytest -m slow` a long one; `python tests/test_fuzz.py --cases 10000 --seed 1` a campaign
of any size with its figures. Every failure names its seed and case; `--case N` reruns one.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import hashlib
import io
import json
import multiprocessing
import os
import random
import shutil
import sys
import tempfile
import time
import traceback
from collections import Counter
from dataclasses import dataclass, field

import pytest

DEFAULT_CASES = 800  # about 20 s on the shared 2-core machine
SLOW_CASES = 10_000  # about 4 minutes
CASE_SECONDS = 30.0  # a case past this is a hang (the slowest valid cases take a few s)
SEED = int(os.environ.get("EDGEAA_FUZZ_SEED", "20240615"))

HOSTILE_NUMBERS = [
    "inf", "-inf", "nan", "NaN", "Infinity", "1e309", "-1e309", "0e1000000000",
    "1e-1000000000", "9" * 5000, "-" + "9" * 400, "1e40", "-0", "0x10", "1/3", "1_000",
    "", " ", "1e", ".", "+", "4294967296", "-1", "65536", "1.5", "0",
]  # fmt: skip
HOSTILE_JSON_VALUES = [
    None, True, [], {}, [1, 2], "12", -1, 0, 1e300, -1e300, 10**30, 1.5, 2**63,
    [[0, 0], [1, 1]], "M 0 0 L 1 1 Z", {"points": []},
]  # fmt: skip
OUTPUTS = ["out.png", "sub/out.png", ".", "dir.png", "scene.json", "out.jpg", "/dev/full",
           "out.PNG", "", "-"]  # fmt: skip


# -- scenes ------------------------------------------------------------------------------------


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


def _polygon(rng: random.Random) -> dict:
    shape = rng.choice(["points", "contours", "path"])
    if shape == "points":
        item = {"points": [[_coordinate(rng), _coordinate(rng)] for _ in range(rng.randint(3, 7))]}
    elif shape == "contours":
        item = {
            "contours": [
                [[_coordinate(rng), _coordinate(rng)] for _ in range(rng.randint(3, 6))]
                for _ in range(rng.randint(1, 3))
            ]
        }
    else:
        item = {"path": _path(rng)}
    if rng.random() < 0.7:
        item["intensity"] = rng.randint(0, 255)
    if rng.random() < 0.4:
        item["fill_rule"] = rng.choice(["nonzero", "evenodd", "non-zero", "even-odd"])
    return item


def scene_data(rng: random.Random) -> dict:
    data = {
        "width": rng.randint(1, 64),
        "height": rng.randint(1, 64),
        "polygons": [_polygon(rng) for _ in range(rng.randint(0, 4))],
    }
    if rng.random() < 0.5:
        data["background"] = rng.randint(0, 255)
    if rng.random() < 0.3:
        data["tolerance"] = rng.choice([1 / 16, 0.5, 0.01, 1 / 1024])
    return data


def _leaves(data, path=()):
    """Every (container, key) in the JSON data, so a mutation can replace any value."""
    items = data.items() if isinstance(data, dict) else enumerate(data)
    for key, value in items:
        yield data, key
        if isinstance(value, dict | list):
            yield from _leaves(value, (*path, key))


def mutate_data(rng: random.Random, data: dict) -> None:
    kind = rng.randrange(4)
    places = list(_leaves(data))
    if kind == 0 and places:  # a value of the wrong type or out of every range
        container, key = rng.choice(places)
        container[key] = copy.deepcopy(rng.choice(HOSTILE_JSON_VALUES))  # never shared
    elif kind == 1:  # huge sizes, tiny tolerance, giant control points
        key, value = rng.choice(
            [("width", 65536), ("height", 1 << 20), ("tolerance", 1e-300), ("tolerance", 0.0)]
        )
        data[key] = value
    elif kind == 2:
        polygons = data.get("polygons")
        data["polygons"] = polygons = polygons if isinstance(polygons, list) else []
        polygons.append(
            rng.choice(
                [
                    {"path": "M 0 0 C 1e300 0 0 1e300 10 10 Z"},
                    {"path": "M 0 0 L 10 0 L 10 10 " + rng.choice(["L", "C 1 2", "Q", "m"])},
                    {"path": "M 0 0 L 10 0 L 10 10 A 1 1 0 0 0 5 5 Z"},
                    {"points": [[0, 0], [0, 0], [0, 0]]},
                    {"points": [[0, 0], [4, 4], [0, 4], [4, 0]], "fill_rule": ["evenodd"]},
                    {"contours": [[[0, 0], [8, 0], [8, 8]], [[0, 0], [8, 0], [8, 8]]]},
                    {"points": [[0, 0], [1e6, 0], [0, 1e6]]},
                    {"path": "M 0 0 " + "l 1 0 " * 20000 + "z"},
                ]
            )
        )
    elif places:  # an unknown key
        container, _ = rng.choice(places)
        if isinstance(container, dict):
            container[rng.choice(["widht", "colour", "Points"])] = 1


def mutate_text(rng: random.Random, text: bytes) -> bytes:
    kind = rng.randrange(8)
    if kind == 0:
        return text.replace(b'"width": ', b'"width": 3, "width": ', 1)  # a duplicate key
    if kind == 1:
        depth = rng.choice([100, 5000, 100000])
        return b"[" * depth + b"]" * depth
    if kind == 2:
        return text[: rng.randrange(max(1, len(text)))]  # cut short
    if kind == 3:
        at = rng.randrange(max(1, len(text)))
        return text[:at] + rng.choice([b"\xff", b"\xc3", b"\x00", b"\xef\xbb\xbf"]) + text[at:]
    literal = rng.choice(
        [b"NaN", b"Infinity", b"-Infinity", b"1e400", b"0e1000000000", b"1" * 5000, b"-0.0"]
    )
    digits = [i for i, c in enumerate(text) if 48 <= c <= 57 and not 48 <= text[i - 1] <= 57]
    if not digits:
        return text
    at = rng.choice(digits)
    end = at
    while end < len(text) and (48 <= text[end] <= 57 or text[end] in b".-eE+"):
        end += 1
    return text[:at] + literal + text[end:]


def scene_file(rng: random.Random) -> bytes:
    data = scene_data(rng)
    for _ in range(rng.choice([0, 0, 0, 1, 1, 2, 3])):
        mutate_data(rng, data)
    text = json.dumps(data, indent=rng.choice([None, 1])).encode()
    if rng.random() < 0.25:
        text = mutate_text(rng, text)
    return text


# -- command lines -----------------------------------------------------------------------------


def _config_options(rng: random.Random) -> list[str]:
    options = []
    for name, good in (
        ("--coord-bits", ["6", "8", "11", "16"]),
        ("--subpixel-bits", ["0", "2", "4", "8"]),
        ("--intensity-bits", ["1", "8", "10", "16"]),
        ("--mode", ["pw", "paper", "seg2", "seg4"]),
        ("--accumulator", ["exact", "truncated"]),
        ("--frac-bits", ["6", "20", "48"]),
    ):
        if rng.random() < 0.12:
            bad = rng.random() < 0.4
            options += [name, rng.choice(HOSTILE_NUMBERS if bad else good)]
    return options


def render_argv(rng: random.Random) -> list[str]:
    argv = ["render"]
    if rng.random() < 0.96:
        argv.append("scene.json")
    if rng.random() < 0.04:
        argv += ["--builtin", rng.choice(["starburst", "text", "circle"])]
    output = rng.choice(OUTPUTS) if rng.random() < 0.25 else "out.png"
    output = None if rng.random() < 0.15 else output
    if output is not None:
        argv += ["-o", output]
    for flag, chance in (
        ("--stats", 0.1), ("--no-skip", 0.1), ("--error", 0.08), ("--compare", 0.04),
        ("--quiet", 0.5),
    ):  # fmt: skip
        if rng.random() < chance:
            argv.append(flag)
    if rng.random() < 0.06:
        argv += ["--crop", rng.choice(["0,0,8,8", "1,2", "5,5,1,1", "0,0," + "9" * 400])]
    if rng.random() < 0.05:
        argv += ["--engine", rng.choice(["model", "spice"])]
    argv += _config_options(rng)
    if rng.random() < 0.05:  # a repeated option
        argv += ["--mode", "paper", "--mode", "seg4"]
    return argv


def edge_argv(rng: random.Random) -> list[str]:
    def number():
        if rng.random() < 0.1:
            return rng.choice(HOSTILE_NUMBERS)
        return str(rng.choice([rng.randint(0, 100), rng.randint(0, 1600) / 16, 2047.9375]))

    argv = ["edge", *(number() for _ in range(rng.choice([4] * 8 + [3, 5])))]
    if rng.random() < 0.2:
        argv += ["--inside", rng.choice(["left", "right", "up"])]
    if rng.random() < 0.1:
        argv += ["--inside", "left"]
    if rng.random() < 0.15:
        argv += ["--clip", *(rng.choice(["0", "5", "100", "-1", "9" * 50]) for _ in range(4))]
    for name in ("--i-in", "--i-out"):
        if rng.random() < 0.1:
            argv += [name, rng.choice(["0", "255", "256", "-1", "1e3", "9" * 5000])]
    if rng.random() < 0.3:
        argv.append("--json")
    return argv + _config_options(rng)


# Slow commands get at least one bad option: the case checks that it fails before any work.
BAD_OPTIONS = {
    "demo": [["--spokes", "0"], ["--spokes", "9" * 5000], ["-o", "demo.gif"],
             ["-o", "sub/d.png"], ["--coord-bits", "40"]],
    "verilog": [["-o", "core.txt"], ["-o", "/dev/full"], ["--name", "1x"], ["-o", "."],
                ["--intensity-bits", "0"], ["--name", "a", "--name", "b"]],
    "synth": [["--target", "xc7"], ["--seed", "-1"], ["--seed", "1e9"], ["--mode", "nan"]],
    "plot": [["error-vs-slope", "--step", "0"], ["error-vs-slope", "--step", "nan"],
             ["error-vs-slope", "--offsets", "0"], ["error-vs-slope", "-o", "x.gif"],
             ["error-vs-slope", "--length", "100000"], ["nonsense"]],
    "bench": [["--edges", "0"], ["--seed", "-5"], ["--repeats", "1e9"], ["-o", "b.bmp"],
              ["--coord-bits", "5"]],
    "stress": [["--widths", "1,2"], ["--widths", "9" * 5000], ["--intensities", "x"],
               ["--plot-intensity-bits", "3"], ["--subpixel-bits", "99"], ["-o", "s.txt"]],
}  # fmt: skip
GOOD_OPTIONS = {
    "demo": [["--spokes", "8"], ["--quiet"]],
    "verilog": [["--mode", "seg4"], ["--name", "core"]],
    "synth": [["--target", "ice40"]],
    "plot": [],
    "bench": [["--quick"], ["--no-synth"]],
    "stress": [["--quick"], ["--skip-bounds"]],
}


def other_argv(rng: random.Random) -> list[str]:
    command = rng.choice(list(BAD_OPTIONS))
    argv = [command]
    bad = rng.sample(BAD_OPTIONS[command], rng.randint(1, 2))
    if command == "plot":
        return argv + bad[0]
    good = [o for o in GOOD_OPTIONS[command] if rng.random() < 0.5]
    for options in rng.sample(bad + good, len(bad + good)):
        argv += options
    return argv


@dataclass
class Case:
    index: int
    argv: list[str]
    scene: bytes | None = None
    files: dict[str, bytes] = field(default_factory=dict)  # other files before the run
    expect_error: bool = False  # a slow command with a bad option


def make_case(seed: int, index: int) -> Case:
    rng = random.Random(f"{seed}/{index}")
    kind = rng.random()
    if kind < 0.7:
        case = Case(index, render_argv(rng), scene_file(rng))
    elif kind < 0.9:
        case = Case(index, edge_argv(rng))
    else:
        case = Case(index, other_argv(rng), expect_error=True)
    if "-o" in case.argv and rng.random() < 0.3:  # an output that exists already
        target = case.argv[case.argv.index("-o") + 1]
        if target.endswith((".png", ".v", ".PNG")) and "/" not in target and target != "dir.png":
            case.files[target] = b"the previous file"
    if rng.random() < 0.02:
        case.argv = []  # a plain `edgeaa`
    return case


# -- running a case ----------------------------------------------------------------------------


def _worker(connection) -> None:
    """Run cases sent over the pipe: (folder, argv) -> (status, out, err, traceback)."""
    from edgeaa.cli import main

    while True:
        folder, argv = connection.recv()
        os.chdir(folder)
        out, err = io.StringIO(), io.StringIO()
        status, crash = None, None
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                status = main(argv)
            except SystemExit as exit_:  # --help
                status = exit_.code
            except BaseException:  # every escape is the finding
                crash = traceback.format_exc()
        connection.send((status, out.getvalue(), err.getvalue(), crash))


class Runner:
    """A worker process that is replaced when a case hangs."""

    def __init__(self, seconds: float = CASE_SECONDS):
        self.seconds = seconds
        self.context = multiprocessing.get_context("fork")
        self.process = None

    def _start(self):
        self.connection, child = self.context.Pipe()
        self.process = self.context.Process(target=_worker, args=(child,), daemon=True)
        self.process.start()

    def run(self, folder: str, argv: list[str]):
        if self.process is None or not self.process.is_alive():
            self._start()
        self.connection.send((folder, argv))
        if self.connection.poll(self.seconds):
            return self.connection.recv()
        self.close()
        return None  # a hang

    def close(self):
        if self.process is not None:
            self.process.kill()
            self.process.join()
            self.process = None


def _snapshot(folder: str) -> dict[str, str]:
    """Every file under the folder and the hash of its bytes."""
    out = {}
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            path = os.path.join(root, name)
            relative = os.path.relpath(path, folder)
            if os.path.isdir(path):
                out[relative + "/"] = ""
            else:
                with open(path, "rb") as file:
                    out[relative] = hashlib.sha256(file.read()).hexdigest()
    return out


def _whole(path: str) -> bool:
    """Whether an output is complete: a PNG that decodes, or Verilog that ends its module."""
    if path.endswith((".v", ".sv")):
        with open(path) as file:
            return file.read().rstrip().endswith("endmodule")
    from PIL import Image

    try:
        with Image.open(path) as image:
            image.load()
        return True
    except Exception:  # any failure to decode is a broken file
        return False


def check_case(case: Case, runner: Runner) -> tuple[str, str]:
    """Run one case; return (outcome, detail): 'ok', 'error' or the name of a failure."""
    folder = tempfile.mkdtemp(prefix="edgeaa-fuzz-")
    try:
        if case.scene is not None:
            with open(os.path.join(folder, "scene.json"), "wb") as file:
                file.write(case.scene)
        os.mkdir(os.path.join(folder, "dir.png"))
        for name, content in case.files.items():
            with open(os.path.join(folder, name), "wb") as file:
                file.write(content)
        before = _snapshot(folder)
        start = time.perf_counter()
        result = runner.run(folder, case.argv)
        if result is None:
            return "hang", f"no answer in {runner.seconds:.0f} s"
        return _judge(case, folder, before, result, time.perf_counter() - start)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _judge(case: Case, folder: str, before: dict, result, seconds: float) -> tuple[str, str]:
    status, out, err, crash = result
    if crash is not None or "Traceback" in err:
        return "traceback", (crash or err).strip().splitlines()[-1]
    after = _snapshot(folder)
    if "scene.json" in before and after.get("scene.json") != before["scene.json"]:
        return "overwritten input", "scene.json changed"
    touched = [name for name in after if after[name] != before.get(name)]
    touched += [name for name in before if name not in after]
    if status == 2:
        lines = [line for line in err.splitlines() if not line.startswith("render: ")]
        if len(lines) != 1 or not lines[0].startswith("edgeaa") or out:
            return "bad error", repr(err[:300])
        if touched:
            return "half-written file", f"{touched} written by a failed command"
        return "error", lines[0]
    if status != 0:
        return "bad status", f"status {status}: {err[:300]!r}"
    if case.expect_error:
        return "accepted bad input", "exit 0"
    for name in touched:
        if name != _output(case.argv):
            return "half-written file", f"{name} left behind"
        if not _whole(os.path.join(folder, name)):
            return "half-written file", f"{name} is not whole"
    return "ok", f"{seconds:.2f} s"


def _output(argv: list[str]) -> str | None:
    return argv[argv.index("-o") + 1] if "-o" in argv[:-1] else None


FAILURES = (
    "traceback", "hang", "bad error", "bad status", "overwritten input", "half-written file",
    "accepted bad input",
)  # fmt: skip


def campaign(seed: int, cases: int, first: int = 0, report=None) -> tuple[Counter, list]:
    """Run cases first .. first + cases - 1; returns the outcome counts and the failures."""
    runner = Runner()
    counts, failures = Counter(), []
    try:
        for index in range(first, first + cases):
            case = make_case(seed, index)
            outcome, detail = check_case(case, runner)
            counts[outcome] += 1
            if outcome in FAILURES:
                failures.append((index, outcome, detail, case.argv))
                if report:
                    report(f"seed {seed} case {index}: {outcome}: {detail}; argv {case.argv}")
    finally:
        runner.close()
    return counts, failures


def _describe(seed: int, failures: list) -> str:
    lines = [f"fuzz seed {seed}: {len(failures)} failing cases (rerun one with "
             f"python tests/test_fuzz.py --seed {seed} --case N)"]  # fmt: skip
    lines += [f"  case {i}: {outcome}: {detail}; argv {argv[:12]}" for i, outcome, detail, argv
              in failures[:20]]  # fmt: skip
    return "\n".join(lines)


# -- the tests ---------------------------------------------------------------------------------


def test_fuzz_the_command_line_and_the_scene_parser():
    counts, failures = campaign(SEED, DEFAULT_CASES)
    assert not failures, _describe(SEED, failures)
    # The generator must reach both sides: clean errors and successful renders.
    assert counts["error"] > DEFAULT_CASES // 4 and counts["ok"] > DEFAULT_CASES // 10, counts


@pytest.mark.slow
def test_fuzz_long_run():
    counts, failures = campaign(SEED + 1, SLOW_CASES)
    assert not failures, _describe(SEED + 1, failures)


def test_the_fuzz_checks_can_fail(tmp_path, monkeypatch):
    """Each check catches what it is for: a traceback, a hang, a stray or broken file."""
    from edgeaa import edge_cli

    folder, case = str(tmp_path), Case(0, ["edge", "0", "0", "3", "1", "-o", "t.png"])
    (tmp_path / "t.png").write_bytes(b"\x89PNG\r\n\x1a\n cut short")
    assert not _whole(str(tmp_path / "t.png"))
    assert _judge(case, folder, {}, (0, "", "", None), 0)[0] == "half-written file"
    assert _judge(case, folder, {}, (2, "", "edgeaa: error: x\n", None), 0)[0] == (
        "half-written file"  # t.png appeared although the command failed
    )
    assert _judge(case, folder, {}, (2, "", "edgeaa: one\ntwo\n", None), 0)[0] == "bad error"
    # The worker is forked from here: it inherits a model that crashes, then one that hangs.
    monkeypatch.setattr(edge_cli, "run_edge", lambda config, edge: {}["no such key"])
    assert check_case(Case(1, ["edge", "0", "0", "3", "1"]), Runner(5.0))[0] == "traceback"
    monkeypatch.setattr(edge_cli, "run_edge", lambda config, edge: time.sleep(60))
    assert check_case(Case(2, ["edge", "0", "0", "3", "1"]), Runner(1.0))[0] == "hang"


def test_generated_cases_are_reproducible():
    assert make_case(7, 3) == make_case(7, 3)
    assert make_case(7, 3) != make_case(7, 4)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="a seeded fuzz campaign over edgeaa")
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--cases", type=int, default=10_000)
    parser.add_argument("--case", type=int, help="run this one case and print it")
    args = parser.parse_args(argv)
    if args.case is not None:
        case = make_case(args.seed, args.case)
        print("argv:", case.argv)
        if case.scene is not None:
            print("scene.json:", case.scene[:2000])
        print(check_case(case, Runner()))
        return 0
    start = time.perf_counter()
    counts, failures = campaign(args.seed, args.cases, report=print)
    seconds = time.perf_counter() - start
    print(f"seed {args.seed}, {args.cases} cases in {seconds:.0f} s: " + ", ".join(
        f"{counts[k]} {k}" for k in ("ok", "error", *FAILURES)))  # fmt: skip
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
