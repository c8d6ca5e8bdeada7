"""The command line: output formats, and one-line errors with exit status 2 for bad input."""

import argparse
import json
import subprocess
import sys

import pytest

from edgeaa.cli import main
from edgeaa.command import add_config_options, config_arguments, config_from_args
from edgeaa.model import Clip, Edge, EdgeConfig, run_edge


def run_cli(capsys, *argv):
    status = main(list(argv))
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_edge_json_matches_model(capsys):
    status, out, err = run_cli(capsys, "edge", "1.5", "2", "9.25", "5.0625", "--json")
    assert status == 0 and err == ""
    rows = json.loads(out)
    config = EdgeConfig()
    result = run_edge(config, Edge.from_pixels(config, "1.5", "2", "9.25", "5.0625"))
    assert [(r["x"], r["y"], r["value"]) for r in rows] == [
        (w.x, w.y, w.value) for w in result.writes
    ]
    assert [r["coverage"] for r in rows] == [result.coverage(w) for w in result.writes]


def test_edge_options_reach_the_model(capsys):
    argv = ["edge", "10", "0", "3", "9.5", "--inside", "right", "--mode", "seg4"]
    argv += ["--accumulator", "truncated", "--i-in", "10", "--i-out", "200", "--json"]
    argv += ["--coord-bits", "12", "--subpixel-bits", "2", "--frac-bits", "30"]
    status, out, _ = run_cli(capsys, *argv)
    assert status == 0
    config = EdgeConfig(
        coord_bits=12, subpixel_bits=2, frac_bits=30, mode="seg4", accumulator="truncated"
    )
    edge = Edge.from_pixels(config, 10, 0, 3, "9.5", inside="right", i_in=10, i_out=200)
    expected = run_edge(config, edge)
    assert [(r["x"], r["y"], r["value"]) for r in json.loads(out)] == [
        (w.x, w.y, w.value) for w in expected.writes
    ]
    # The defaults would give other writes: the options really changed something.
    default = run_edge(EdgeConfig(), Edge.from_pixels(EdgeConfig(), 10, 0, 3, "9.5"))
    assert [(w.x, w.y, w.value) for w in default.writes] != [
        (w.x, w.y, w.value) for w in expected.writes
    ]


def test_edge_clip_reaches_the_model(capsys):
    status, out, _ = run_cli(
        capsys, "edge", "10", "10", "50", "20", "--clip", "20", "0", "22", "12"
    )
    assert status == 0
    config = EdgeConfig()
    edge = Edge.from_pixels(config, 10, 10, 50, 20, clip=Clip(20, 0, 22, 12))
    rows = [tuple(int(v) for v in line.split()[:3]) for line in out.splitlines()[1:]]
    assert rows == [(w.x, w.y, w.value) for w in run_edge(config, edge).writes]
    assert sorted({x for x, _, _ in rows}) == [20, 21, 22]


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["edge", "0", "0", "0", "0"], "zero-length edge"),
        (["edge", "0", "0", "3000", "1"], "outside the configured range [0, 2047.9375] px"),
        (["edge", "0", "0", "-1", "1"], "outside the configured range"),
        (["edge", "0", "0", "3.03", "1"], "not a multiple of the sub-pixel step 1/16"),
        (["edge", "0", "0", "3", "1", "--mode", "foo"], "invalid choice: 'foo'"),
        (["edge", "0", "0", "3", "1", "--coord-bits", "40"], "coord_bits must be in [2, 16]"),
        (["edge", "0", "0", "3", "1", "--subpixel-bits", "9"], "subpixel_bits must be in [0, 8]"),
        (["edge", "0", "0", "3", "1", "--frac-bits", "3"], "frac_bits must be in [6, 48]"),
        (["edge", "0", "0", "3", "1", "--i-in", "300"], "I_in must be an integer in [0, 255]"),
        (["edge", "0", "0", "3", "1", "--i-in", "0"], "I_in equals I_out"),
        (["edge", "0", "0", "x", "1"], "X1 must be a decimal number"),
        (["edge", "0", "0", "3", "1", "--clip", "0", "0", "3000", "9"], "clip x_max must be"),
        (["edge", "0", "0"], "required"),
        (["nonsense"], "invalid choice"),
    ],
)
def test_bad_input_is_one_line_with_status_2(capsys, argv, fragment):
    status, out, err = run_cli(capsys, *argv)
    assert status == 2
    assert fragment in err
    assert err.count("\n") == 1, f"expected one line, got {err!r}"
    assert "Traceback" not in err and out == ""


def test_console_script_exit_status():
    proc = subprocess.run(
        [sys.executable, "-m", "edgeaa", "edge", "0", "0", "0", "0"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 2
    expected = "edgeaa edge: error: zero-length edge: P0 and P1 are the same point"
    assert proc.stderr.strip() == expected


def test_demo_reports_each_mode_within_its_bound(capsys, tmp_path):
    plot = tmp_path / "demo.png"
    status, out, _ = run_cli(capsys, "demo", "--spokes", "16", "-o", str(plot))
    assert status == 0
    assert plot.stat().st_size > 10_000
    rows = {line.split()[0]: line.split() for line in out.splitlines()[2:6]}
    assert set(rows) == {"pw", "paper", "seg2", "seg4"}
    for mode, (_, writes, _worst, worst_over_k, c_n, over_bound) in rows.items():
        assert int(writes) > 0
        # Every edge within its own bound (c_N k plus the fixed-point units); the estimate's
        # c_N k is reached to within those units.
        assert 0.9 < float(over_bound) <= 1, mode
        assert float(worst_over_k) >= 0.9 * float(c_n), mode


def test_verilog_command_writes_the_core_with_stable_ports(capsys, tmp_path):
    path = tmp_path / "core.v"
    status, _, err = run_cli(capsys, "verilog", "--mode", "seg2", "-o", str(path))
    assert status == 0 and "wrote" in err
    source = path.read_text()
    assert "module edgeaa_core(" in source
    for port in (
        "clk",
        "rst",
        "edges__valid",
        "edges__ready",
        "edges__payload__x0",
        "edges__payload__inside",
        "writes__payload__lane1__value",
        "writes__payload__lane1_valid",
        "writes__payload__last",
        "errors",
    ):
        assert f" {port};" in source, port


def test_verilog_command_rejects_bad_configuration(capsys):
    status, _, err = run_cli(capsys, "verilog", "--intensity-bits", "0")
    assert status == 2 and "intensity_bits must be in [1, 16]" in err


def test_synth_rejects_an_unknown_target(capsys):
    status, _, err = run_cli(capsys, "synth", "--target", "xc7")
    assert status == 2 and "invalid choice: 'xc7'" in err


@pytest.mark.slow
def test_synth_prints_both_cores_and_their_ratio(capsys):
    status, out, _ = run_cli(capsys, "synth", "--target", "ice40", "--coord-bits", "8")
    assert status == 0
    rows = {tuple(line.split()[:2]): line.split()[2:] for line in out.splitlines()[3:]}
    edgeaa, baseline, ratio = (rows["ice40", n] for n in ("edgeaa", "bresenham", "ratio"))
    assert all(float(v) > 0 for v in edgeaa + baseline)
    assert float(ratio[0]) == pytest.approx(int(edgeaa[0]) / int(baseline[0]), abs=0.01)


# -- the command registry --------------------------------------------------------------------

COMMAND_NAMES = [
    "board", "edge", "demo", "verilog", "synth", "verify", "plot", "bench", "stress", "render"
]  # fmt: skip


def test_every_registered_command_is_in_the_help_in_order(capsys):
    from edgeaa.command import COMMANDS

    assert list(COMMANDS) == COMMAND_NAMES
    with pytest.raises(SystemExit) as exit_info:
        main(["--help"])
    assert exit_info.value.code == 0
    help_text = capsys.readouterr().out
    listed = [line.split()[0] for line in help_text.splitlines() if line.startswith("    ")]
    listed = [name for name in listed if name in COMMANDS]
    assert listed == COMMAND_NAMES
    for name, command in COMMANDS.items():
        assert command.help.split()[0] in help_text, name


def test_command_modules_do_not_import_the_entry_point():
    # The commands register on import; only the entry point may import them all (no cycle).
    program = (
        "import sys\n"
        "import edgeaa.board_cli, edgeaa.edge_cli, edgeaa.verify_cli, edgeaa.analysis.cli\n"
        "import edgeaa.render.cli\n"
        "from edgeaa.command import COMMANDS\n"
        "print(' '.join(COMMANDS), 'edgeaa.cli' in sys.modules)\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", program], capture_output=True, text=True, check=True
    )
    assert proc.stdout.split() == [*COMMAND_NAMES, "False"]


def test_a_step_progress_bar_ends_its_line_on_a_terminal(monkeypatch):
    import io

    from edgeaa import progress

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    monkeypatch.setattr(progress, "DELAY", 0.0)
    monkeypatch.setattr(progress, "EVERY", 0.0)
    stream = Terminal()
    bar = progress.ProgressBar("job", 2, stream=stream)
    bar.step("first")
    bar.step("second")
    text = stream.getvalue()
    assert text.count("\r") == 2 and "100.0% (2/2, " in text and text.endswith("\n")


# -- robustness: every bad input one line with status 2, nothing half-written ---------------

HUGE = "9" * 5000


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["edge", "0", "0", "inf", "1"], "X1 must be a decimal number"),
        (["edge", "0", "0", "nan", "1"], "X1 must be a decimal number"),
        (["edge", "0", "0", "1e309", "1"], "out of range (exponents up to +-60)"),
        (["edge", "0", "0", "1e40", "1"], "outside the configured range"),
        (["edge", "0", "0", "1e-1000000000", "1"], "out of range"),
        (["edge", "0", "0", HUGE, "1"], "at most 60 characters"),
        (["edge", "0", "0", "3", "1", "--clip", "0", "0", HUGE, "9"], "(5002 characters)"),
        (["edge", "0", "0", "3", "1", "--coord-bits", HUGE], "must be an integer"),
        (["edge", "0", "0", "3", "1", "--inside", "left", "--inside", "right"], "given twice"),
        (["demo", "--spokes", "1000000000"], "must be an integer in [1, 512]"),
        (["plot", "error-vs-slope", "--step", "1e-300"], "must be a number in [0.01, 45]"),
        (["plot", "error-vs-slope", "--step", "nan"], "must be a number in [0.01, 45]"),
        (["bench", "--seed", "-1"], "must be an integer in [0, 4294967295]"),
        (["verilog", "--name", "a b"], "must be a plain Verilog identifier"),
        (["verilog", "-o", "/dev/full"], "unsupported format (allowed: .v, .sv)"),
        ([], "give a command (board, edge, demo"),
    ],
)
def test_hostile_arguments_are_one_line_errors(capsys, argv, fragment):
    status, out, err = run_cli(capsys, *argv)
    assert (status, out) == (2, "")
    assert fragment in err and err.count("\n") == 1 and len(err) < 300, err


def test_an_exponent_of_a_billion_on_zero_is_zero_and_quick(capsys):
    # Fraction("0e1000000000") would compute 10**1000000000: the argument is read first.
    status, out, _ = run_cli(capsys, "edge", "0e1000000000", "0", "3", "1", "--json")
    assert status == 0
    assert json.loads(out) == json.loads(run_cli(capsys, "edge", "0", "0", "3", "1", "--json")[1])


def test_output_checks_come_before_the_work(capsys, tmp_path):
    folder = tmp_path / "figures"
    folder.mkdir()
    cases = [
        (["verilog", "-o", str(folder)], "is a directory"),
        (["verilog", "-o", str(tmp_path / "missing" / "core.v")], "does not exist"),
        (["demo", "-o", str(tmp_path / "demo.gif")], "unsupported format"),
        (["plot", "error-vs-slope", "-o", str(tmp_path / "x" / "p.png")], "does not exist"),
    ]
    (tmp_path / "dir.v").mkdir()
    cases.append((["verilog", "-o", str(tmp_path / "dir.v")], "is a directory"))
    for argv, fragment in cases:
        status, _, err = run_cli(capsys, *argv)
        assert status == 2 and fragment in err and err.count("\n") == 1, (argv, err)


def test_a_failed_write_leaves_the_old_file_and_no_temporary(capsys, tmp_path, monkeypatch):
    from pathlib import Path

    from edgeaa import edge_cli

    class FullDisk(type(Path())):
        def write_text(self, text):
            with open(self, "w") as file:
                file.write(text[:1000])  # half the core, then the disk is full
            raise OSError(28, "No space left on device")

    monkeypatch.setattr(edge_cli, "Path", FullDisk)
    target = tmp_path / "core.v"
    target.write_text("the previous core\n")
    status, _, err = run_cli(capsys, "verilog", "-o", str(target))
    assert status == 2 and "cannot write" in err and "No space left on device" in err
    assert target.read_text() == "the previous core\n"
    assert [p.name for p in tmp_path.iterdir()] == ["core.v"]


def test_atomic_output_renames_only_on_success(tmp_path):
    from pathlib import Path

    from edgeaa.command import UsageError, atomic_output

    target = tmp_path / "out.png"
    target.write_bytes(b"old")
    with pytest.raises(RuntimeError), atomic_output("edgeaa test", str(target)) as temporary:
        Path(temporary).write_bytes(b"half")
        raise RuntimeError("killed half way")
    assert target.read_bytes() == b"old" and len(list(tmp_path.iterdir())) == 1
    with atomic_output("edgeaa test", str(target)) as temporary:
        Path(temporary).write_bytes(b"new")
    assert target.read_bytes() == b"new" and len(list(tmp_path.iterdir())) == 1
    missing = str(tmp_path / "gone" / "x.png")
    with pytest.raises(UsageError, match="cannot write"), atomic_output("edgeaa test", missing):
        pass


def test_a_closed_pipe_ends_quietly():
    program = "import sys; from edgeaa.cli import main; sys.exit(main(sys.argv[1:]))"
    proc = subprocess.Popen(
        # --json: about 130 KB, more than a pipe holds, so the writer is still writing when
        # the reader closes (38 KB of text could all fit in the pipe and end with status 0).
        [sys.executable, "-c", program, "edge", "0", "0", "2000", "1", "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    proc.stdout.read(1)
    proc.stdout.close()  # as `| head -1` does
    err = proc.stderr.read().decode()
    proc.stderr.close()
    assert proc.wait() == 141 and err == "", err


def test_a_full_disk_on_stdout_is_one_line():
    with open("/dev/full", "w") as full:
        proc = subprocess.run(
            [sys.executable, "-m", "edgeaa", "edge", "0", "0", "2000", "1"],
            stdout=full,
            stderr=subprocess.PIPE,
            text=True,
            check=False,
        )
    assert proc.returncode == 2
    assert proc.stderr == "edgeaa: error: cannot write the output: No space left on device\n"


def test_a_ticking_bar_shows_a_step_without_counts(monkeypatch):
    import io
    import time

    from edgeaa import progress

    monkeypatch.setattr(progress, "EVERY", 0.01)
    stream = io.StringIO()
    bar = progress.ProgressBar("synth", total=2, stream=stream, delay=0.0)
    with bar.ticking("ice40 edgeaa"):
        time.sleep(0.3)  # a tool that reports nothing: the bar still moves (not a tty: 0.1 s)
    lines = stream.getvalue().splitlines()
    assert len(lines) >= 2 and all("ice40 edgeaa" in line and "(0/2, " in line for line in lines)


@pytest.mark.parametrize(
    "config",
    [
        EdgeConfig(),
        EdgeConfig(coord_bits=15, subpixel_bits=8, intensity_bits=12, mode="seg4"),
        EdgeConfig(coord_bits=4, subpixel_bits=0, intensity_bits=4, accumulator="truncated"),
        EdgeConfig(mode="pw", frac_bits=30),
    ],
)
def test_config_arguments_read_back_as_the_config(config):
    """The reproducers' options (`config_arguments`) are the inverse of the parser's."""
    parser = argparse.ArgumentParser()
    add_config_options(parser)
    parsed = config_from_args(parser.parse_args(config_arguments(config)))
    assert parsed == config and parsed.frac_bits == config.frac_bits


def test_a_missing_optional_package_names_its_extra(capsys, monkeypatch):
    """A command whose optional package is not installed says which extra brings it."""
    from edgeaa import cli

    def missing(args):
        raise ModuleNotFoundError("No module named 'skia'", name="skia")

    parser = cli.build_parser()
    monkeypatch.setattr(cli, "build_parser", lambda only=None: parser)
    parser._subparsers._group_actions[0].choices["bench"].set_defaults(run=missing)
    assert cli.main(["bench"]) == cli.EXIT_MISSING
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "'skia'" in err and '".[peers]"' in err
