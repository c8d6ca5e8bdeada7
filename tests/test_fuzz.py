"""Seeded fuzzing of every `edgeaa` command and option (docs/scenes.md, "Errors and limits").

The cases come from tests/fuzz_cases.py (edge, demo, verilog, synth, verify, plot, bench,
stress, the top level) and tests/fuzz_scenes.py (render and its scene files). Each case runs
in-process (`edgeaa.cli.main`) in a worker process, in a fresh folder, with a strict UTF-8
standard output (as a terminal's), a time limit and a memory cap: the case may add
`Case.memory` bytes to the worker's data (RLIMIT_DATA, inherited by what it starts; not
RLIMIT_AS, which would refuse the WebAssembly tools of `verilog` their reserved address space).
A case fails on:

- traceback: an exception out of `main`; memory: a MemoryError, or the worker killed;
- hang: past the case's time limit (an invalid input past FAST_SECONDS started the work);
- accepted bad input: the generator made the input invalid and the status is not 2;
- bad error: status 2 without exactly one `edgeaa ...: error: ...` line on stderr (progress
  lines aside), or status 1 with more than one; bad status: any status but 0, 1, 2;
- overwritten input: a file that existed changed (the scene, a damaged record refused);
- half-written file: an output of a failed command, a temporary file left, an output that does
  not decode; unasked file: a file written that no option named; bad output: --json that is
  not JSON.

`pytest tests/test_fuzz.py` runs DEFAULT_CASES quick cases; `pytest -m slow` SLOW_CASES full
ones; `python tests/test_fuzz.py --cases 10000 --seed 1` a campaign of any size with its
figures, `--case N` replays one. Every failure names its seed and case.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import multiprocessing
import os
import random
import re
import resource
import shutil
import signal
import sys
import tempfile
import time
import traceback
from collections import Counter

import pytest
from fuzz_cases import (
    Case,
    Draft,
    bench_case,
    board_case,
    demo_case,
    describe,
    edge_case,
    finish,
    plot_case,
    stress_case,
    synth_case,
    top_level_case,
    verify_case,
    verilog_case,
)
from fuzz_scenes import render_case

DEFAULT_CASES = 250  # quick cases: about 30 s on the shared 2-core machine
SLOW_CASES = 10_000
SEED = int(os.environ.get("EDGEAA_FUZZ_SEED", "20240615"))
COMMANDS = [  # (weight, generator)
    (40, render_case), (14, edge_case), (12, verify_case), (8, verilog_case), (6, demo_case),
    (5, synth_case), (4, plot_case), (4, bench_case), (4, stress_case), (2, board_case),
    (1, top_level_case),
]  # fmt: skip
FAILURES = (
    "traceback", "memory", "hang", "accepted bad input", "bad error", "bad status",
    "overwritten input", "half-written file", "unasked file", "bad output",
)  # fmt: skip
PROGRESS = re.compile(r".*\d s\)\s*$")  # a progress bar's line ends "(..., 1.5 s)"


def make_case(seed: int, index: int, quick: bool = False) -> Case:
    rng = random.Random(f"{seed}/{index}/{quick}")
    generator = rng.choices([g for _, g in COMMANDS], [w for w, _ in COMMANDS])[0]
    name = generator.__name__.removesuffix("_case")
    d = Draft(rng, index, *([] if name == "top_level" else [name]))
    generator(d, quick)
    if name != "top_level" and rng.random() < 0.01:
        d.add("--help")  # the help, or an error about an option before it
        d.case.invalid.clear()
        d.case.outputs.clear()
    return finish(d)


# -- running a case ----------------------------------------------------------------------------


def _data_size() -> int:
    with open("/proc/self/status") as file:
        for line in file:
            if line.startswith("VmData:"):
                return int(line.split()[1]) * 1024
    return 0


def _run_in_worker(argv: list[str], memory: int, env: dict[str, str]):
    """One command line, its output captured: (status, out, err, traceback)."""
    from edgeaa.cli import main

    soft, hard = resource.getrlimit(resource.RLIMIT_DATA)
    saved = {key: os.environ.get(key) for key in env}
    os.environ.update(env)
    out_bytes, err_bytes = io.BytesIO(), io.BytesIO()
    out = io.TextIOWrapper(out_bytes, encoding="utf-8", errors="strict", write_through=True)
    err = io.TextIOWrapper(err_bytes, encoding="utf-8", errors="backslashreplace")
    status, crash = None, None
    try:
        resource.setrlimit(resource.RLIMIT_DATA, (_data_size() + memory, hard))
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                status = main(argv)
            except SystemExit as exit_:  # --help
                status = exit_.code
            except BaseException:  # every escape is the finding
                crash = traceback.format_exc()
    finally:
        resource.setrlimit(resource.RLIMIT_DATA, (soft, hard))
        for key, value in saved.items():
            os.environ.pop(key) if value is None else os.environ.__setitem__(key, value)
    err.flush()
    decode = lambda data: data.getvalue().decode("utf-8", "replace")  # noqa: E731
    return status, decode(out_bytes), decode(err_bytes), crash


def _worker(connection) -> None:
    """Run command lines sent over the pipe in their folders; its own process group, so that
    a hang is ended with everything it started."""
    os.setpgrp()
    while True:
        folder, argv, memory, env = connection.recv()
        os.chdir(folder)
        env = {key: value.replace("{folder}", folder) for key, value in env.items()}
        connection.send(_run_in_worker(argv, memory, env))


class Runner:
    """A worker process that is replaced when a case hangs or dies."""

    def __init__(self):
        self.context = multiprocessing.get_context("fork")
        self.process = None

    def _start(self):
        self.connection, child = self.context.Pipe()
        # Not a daemon: `verify --workers 1` starts a pool from it. close() ends it.
        self.process = self.context.Process(target=_worker, args=(child,))
        self.process.start()

    def run(self, folder: str, argv: list[str], seconds: float, memory: int, env: dict):
        """(status, out, err, traceback), "hang" past `seconds`, or "killed" if it died."""
        if self.process is None or not self.process.is_alive():
            self._start()
        self.connection.send((folder, argv, memory, env))
        try:
            if self.connection.poll(seconds):
                return self.connection.recv()
        except (EOFError, ConnectionError):
            self.close()
            return "killed"
        self.close()
        return "hang"

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        """End the worker (not a daemon: a worker left running would hold up the exit)."""
        if self.process is not None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.process.pid, signal.SIGKILL)  # the worker's own group
            self.process.join()
            self.process = None


def _snapshot(folder: str) -> dict[str, str]:
    """Every file under the folder and the hash of its bytes (folders end with '/')."""
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
    """Whether an output is complete: a PNG that decodes, an SVG or PDF that ends, Verilog
    that ends its module."""
    with open(path, "rb") as file:
        data = file.read()
    if path.endswith((".v", ".sv")):
        return data.rstrip().endswith(b"endmodule")
    if path.lower().endswith(".svg"):
        return data.rstrip().endswith(b"</svg>")
    if path.lower().endswith(".pdf"):
        return data.rstrip().endswith(b"%%EOF")
    if not path.lower().endswith(".png"):
        return True
    from PIL import Image

    try:
        with Image.open(path) as image:
            image.load()
        return True
    except Exception:  # any failure to decode is a broken file
        return False


def _prepare(case: Case, folder: str) -> None:
    for name in case.folders:
        os.makedirs(os.path.join(folder, name), exist_ok=True)
    for name, content in case.files.items():
        path = os.path.join(folder, name)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as file:
            file.write(content)


def check_case(case: Case, runner: Runner) -> tuple[str, str]:
    """Run one case; return (outcome, detail): 'ok', 'error', 'skipped' or a failure."""
    folder = tempfile.mkdtemp(prefix="edgeaa-fuzz-")
    try:
        _prepare(case, folder)
        if case.before is not None:  # the run whose record the case damages
            result = runner.run(folder, case.before, 120.0, case.memory, case.env)
            if not isinstance(result, tuple) or result[0] != 0:
                return "skipped", f"the first run gave {str(result)[:200]}"
            for name, content in case.appends.items():
                with open(os.path.join(folder, name), "ab") as file:
                    file.write(content)
        before = _snapshot(folder)
        start = time.perf_counter()
        result = runner.run(folder, case.argv, case.seconds, case.memory, case.env)
        seconds = time.perf_counter() - start
        if result == "hang":
            if case.long_ok:
                return "ok", f"still running after {case.seconds:.0f} s, within its memory"
            if case.invalid:
                return "accepted bad input", f"still running after {case.seconds:.0f} s"
            return "hang", f"no answer in {case.seconds:.0f} s"
        if result == "killed":
            return "memory", "the worker died (killed or crashed)"
        return judge(case, folder, before, result, seconds)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def judge(case: Case, folder: str, before: dict, result, seconds: float) -> tuple[str, str]:
    status, out, err, crash = result
    if crash is not None:
        last = crash.strip().splitlines()[-1]
        return ("memory" if last.startswith("MemoryError") else "traceback"), last
    if "Traceback" in err:
        return "traceback", err.strip().splitlines()[-1]
    lines = [line for line in err.splitlines() if line.strip() and not PROGRESS.match(line)]
    if status not in (0, 1, 2):
        return "bad status", f"status {status}: {err[-300:]!r}"
    if case.invalid and status != 2:
        return "accepted bad input", f"status {status}: {err.strip()[-200:]!r}"
    if status == 2 and (len(lines) != 1 or not re.match(r"edgeaa[\w -]*: error: ", lines[0])):
        return "bad error", repr(err[-300:])
    if status == 1 and len(lines) > 1:
        return "bad error", f"status 1: {err[-300:]!r}"
    failure = _judge_files(case, folder, before, _snapshot(folder), status)
    if failure:
        return failure
    if status == 0 and "--json" in case.argv and "--help" not in case.argv:
        try:
            json.loads(out)
        except ValueError:
            return "bad output", f"--json printed {out[:100]!r}"
    return ("error", lines[0]) if status == 2 else ("ok", f"status {status}, {seconds:.2f} s")


def _judge_files(case: Case, folder: str, before: dict, after: dict, status: int):
    """A changed input, a file left by a failed command or written unasked, a broken output."""

    def asked(name: str) -> bool:
        return any(name == o or (o.endswith("/") and name.startswith(o)) for o in case.outputs)

    changed = {n for n in after if after[n] != before.get(n)} | set(before) - set(after)
    for name in sorted(changed):
        if status != 2 and asked(name):
            if name in after and not name.endswith("/") and not _whole(f"{folder}/{name}"):
                return "half-written file", f"{name!r} is not whole"
        elif name in before:
            return "overwritten input", f"{name!r} changed (status {status})"
        elif status == 2:
            return "half-written file", f"{name!r} written by a failed command"
        elif os.path.basename(name.rstrip("/")).startswith("."):
            return "half-written file", f"{name!r} left behind"
        else:
            return "unasked file", f"{name!r} written though no option named it"
    return None


def campaign(seed: int, cases: int, quick: bool, first: int = 0, report=None):
    """Run cases first .. first + cases - 1; the outcome counts, failures and commands."""
    runner = Runner()
    counts, failures, commands = Counter(), [], Counter()
    try:
        for index in range(first, first + cases):
            case = make_case(seed, index, quick)
            start = time.perf_counter()
            outcome, detail = check_case(case, runner)
            counts[outcome] += 1
            command = (case.argv or ["(none)"])[0]
            commands[command, outcome] += 1
            commands[command, "seconds"] += time.perf_counter() - start
            if outcome in FAILURES:
                failures.append((index, outcome, detail, describe(case)))
                if report:
                    report(f"seed {seed} case {index}: {outcome}: {detail}; {describe(case)}")
            if report and (index + 1) % 500 == 0:
                report(f"seed {seed}: cases to {index}: {dict(counts)}")
    finally:
        runner.close()
    return counts, failures, commands


def _describe(seed: int, quick: bool, failures: list) -> str:
    flag = " --quick" if quick else ""
    lines = [f"fuzz seed {seed}: {len(failures)} failing cases (rerun one with "
             f"python tests/test_fuzz.py --seed {seed}{flag} --case N)"]  # fmt: skip
    lines += [f"  case {i}: {outcome}: {detail}; {what[:300]}" for i, outcome, detail, what
              in failures[:30]]  # fmt: skip
    return "\n".join(lines)


# -- the tests ---------------------------------------------------------------------------------


def test_fuzz_every_command_quick():
    counts, failures, commands = campaign(SEED, DEFAULT_CASES, quick=True)
    assert not failures, _describe(SEED, True, failures)
    # The generator must reach both sides: clean errors and successful runs.
    assert counts["error"] > DEFAULT_CASES // 4 and counts["ok"] > DEFAULT_CASES // 10, counts


@pytest.mark.slow
def test_fuzz_long_run():
    counts, failures, commands = campaign(SEED + 1, SLOW_CASES, quick=False)
    assert not failures, _describe(SEED + 1, False, failures)


def _options(parser: argparse.ArgumentParser, prefix: tuple = ()) -> dict[tuple, set[str]]:
    """Every (sub)command's option strings, by its path of command names."""
    found = {prefix: set()}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found.update(_options(sub, (*prefix, name)))
        else:
            found[prefix] |= set(action.option_strings) or {"(positional)"}
    return found


def test_every_command_and_option_is_generated():
    """A new option of any command must come to the fuzz generator too."""
    from edgeaa.cli import build_parser

    seen: dict[tuple, set[str]] = {}
    for index in range(4000):
        argv = make_case(5, index).argv
        path = tuple(argv[:2]) if argv[:1] == ["plot"] else tuple(argv[:1])
        seen.setdefault(path, set()).update(argv)
    missing = []
    for path, options in _options(build_parser()).items():
        if not path or path == ("plot",):
            continue
        words = seen.get(path, set())
        words |= {"-o", "--output"} if words & {"-o", "--output"} else set()
        lacking = options - words - {"-h", "--help", "(positional)"}  # argparse's own
        missing += [f"{' '.join(path)} {o}" for o in sorted(lacking)]
    assert not missing, missing


def test_the_fuzz_checks_can_fail(tmp_path, monkeypatch):
    """Each check catches what it is for: a traceback, a hang, memory, a stray or broken file,
    a bad input accepted."""
    from edgeaa import edge_cli

    folder, case = str(tmp_path), Case(0, ["edge", "0", "0", "3", "1", "-o", "t.png"])
    (tmp_path / "t.png").write_bytes(b"\x89PNG\r\n\x1a\n cut short")
    assert not _whole(str(tmp_path / "t.png"))
    assert judge(case, folder, {}, (0, "", "", None), 0)[0] == "unasked file"
    case.outputs = ["t.png"]
    assert judge(case, folder, {}, (0, "", "", None), 0)[0] == "half-written file"
    assert judge(case, folder, {}, (2, "", "edgeaa: error: x\n", None), 0)[0] == (
        "half-written file"  # t.png appeared although the command failed
    )
    assert judge(case, folder, {}, (2, "", "edgeaa: error: a\nb\n", None), 0)[0] == "bad error"
    case.invalid = ["a bad input"]
    assert judge(case, folder, {}, (0, "", "", None), 0)[0] == "accepted bad input"
    # The worker is forked from here: it inherits a model that crashes, hangs, eats memory.
    edge = ["edge", "0", "0", "3", "1"]
    for index, (model, outcome) in enumerate(
        [
            (lambda config, edge: {}["no such key"], "traceback"),
            (lambda config, edge: time.sleep(60), "hang"),
            (lambda config, edge: bytearray(1 << 31), "memory"),  # past the 1 GiB cap
            (lambda config, edge: os.kill(os.getpid(), signal.SIGKILL), "memory"),
        ]
    ):
        monkeypatch.setattr(edge_cli, "run_edge", model)
        with Runner() as runner:
            assert check_case(Case(index, edge, seconds=2.0), runner)[0] == outcome


def test_generated_cases_are_reproducible():
    assert make_case(7, 3) == make_case(7, 3)
    assert make_case(7, 3) != make_case(7, 4)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="a seeded fuzz campaign over edgeaa")
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--cases", type=int, default=SLOW_CASES)
    parser.add_argument("--first", type=int, default=0, help="the first case's number")
    parser.add_argument("--quick", action="store_true", help="the default run's quick cases")
    parser.add_argument("--case", type=int, help="run this one case and print it")
    args = parser.parse_args(argv)
    if args.case is not None:
        case = make_case(args.seed, args.case, args.quick)
        print(describe(case))
        for name, content in case.files.items():
            print(f"{ascii(name)}: {content[:2000]!r}")
        with Runner() as runner:
            print(check_case(case, runner))
        return 0
    start = time.perf_counter()
    counts, failures, commands = campaign(
        args.seed, args.cases, args.quick, args.first, report=print
    )
    seconds = time.perf_counter() - start
    print(f"seed {args.seed}, cases {args.first}..{args.first + args.cases - 1} in "
          f"{seconds:.0f} s: " + ", ".join(f"{counts[k]} {k}" for k in
                                           ("ok", "error", "skipped", *FAILURES)))  # fmt: skip
    for name in sorted({command for command, _ in commands}):
        row = {k: round(n, 1) for (command, k), n in commands.items() if command == name}
        print(f"  {name}: {row}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
