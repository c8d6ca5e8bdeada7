"""Progress on every long wait (a bar with rate and time left, or the stage's name), and no
file written unless asked."""

from __future__ import annotations

import io
import json
import time

import pytest
from fixtures import TINY_SCENE

from edgeaa import progress
from edgeaa.cli import main
from edgeaa.progress import ProgressBar


class Clock:
    """A clock the test moves by hand."""

    def __init__(self):
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def eager(monkeypatch):
    """Redraw at every call: the stages a command goes through all reach the stream."""
    monkeypatch.setattr(progress, "DELAY", 0.0)
    monkeypatch.setattr(progress, "EVERY", 0.0)


def test_a_bar_with_a_known_total_shows_its_rate_and_time_left(eager):
    clock, stream = Clock(), io.StringIO()
    bar = ProgressBar("job", 10, stream=stream, clock=clock)
    for _ in range(4):
        clock.now += 2.0  # one step every 2 s: 0.5 per second, 6 steps left = 12 s
        bar.step("work")
    last = stream.getvalue().splitlines()[-1]
    assert "job: work [" in last and "40.0% (4/10, 8.0 s, 2.0 s each, 12 s left)" in last, last


def test_the_rate_of_a_resumed_job_counts_this_run_from_its_start_only(eager):
    clock, stream = Clock(), io.StringIO()
    bar = ProgressBar("verify", stream=stream, unit="edges", clock=clock)
    clock.now = 30.0  # a build first: not in the rate
    bar(600, 1000)  # 600 done before this run: not in the rate
    clock.now = 34.0
    bar(800, 1000)  # 200 in 4 s this run: 50/s, 200 left = 4 s
    assert "(800/1,000, 34 s, 50.0 edges/s, 4.0 s left)" in stream.getvalue()


def test_a_wait_of_unknown_length_shows_the_stage_and_the_time_so_far(monkeypatch):
    monkeypatch.setattr(progress, "EVERY", 0.01)  # not a terminal: a line every 0.1 s
    stream = io.StringIO()
    bar = ProgressBar("render", stream=stream, delay=0.0)
    with bar.ticking("plan"):
        time.sleep(0.35)
    lines = stream.getvalue().splitlines()
    assert len(lines) >= 2, lines
    spinners = {line.split()[2] for line in lines}
    assert all(line.startswith("render: plan ") and line.endswith(" s") for line in lines)
    assert len(spinners) >= 2 and spinners <= set(progress.SPINNER), lines


def _fake_tools(monkeypatch, seconds: float) -> None:
    """Yosys and nextpnr that take `seconds` and write the files `synthesize` reads."""
    from edgeaa.sim import synthesis

    def run(argv, cwd, log_name):
        time.sleep(seconds)
        luts = 2 if log_name == "wrapper.log" else 10
        stat = {"design": {"num_cells_by_type": {"SB_LUT4": luts, "SB_DFF": luts}}}
        stem = {"wrapper.log": "wrapper", "yosys.log": "netlist"}.get(log_name)
        if stem:
            (cwd / f"{stem}.stat.json").write_text(json.dumps(stat))
        else:
            report = {"fmax": {"clk": {"achieved": 100.0}}}
            (cwd / "report.json").write_text(json.dumps(report))
        return ""

    monkeypatch.setattr(synthesis, "_run", run)
    monkeypatch.setattr(synthesis, "find_tool", lambda name, env=None: name)

    def convert(design, **kwargs):
        for part in (design, design.core):  # not elaborated here: not a mistake to warn about
            part._MustUse__silence = True
        return "module top; endmodule\n"

    monkeypatch.setattr(synthesis.verilog, "convert", convert)


def test_synth_names_each_tool_while_it_runs(monkeypatch, capsys):
    """`synth` sat at "0/4" for minutes: now the target, the design and the tool (yosys,
    nextpnr) are on the bar within a moment of the tool's start."""
    monkeypatch.setattr(progress, "EVERY", 0.01)  # not a terminal: a line every 0.1 s
    _fake_tools(monkeypatch, 0.3)
    assert main(["synth", "--target", "ice40"]) == 0
    err = capsys.readouterr().err
    for design in ("edgeaa", "bresenham"):
        for tool in ("yosys (the harness alone)", "yosys", "nextpnr"):
            assert f"synth: ice40 {design}: {tool} [" in err, err


def test_error_vs_slope_names_a_method_while_it_runs(eager, capsys):
    """A method that runs for minutes is named on the bar from its start, not after it."""
    from edgeaa.analysis import slope
    from edgeaa.model import EdgeConfig

    slope.error_vs_slope(EdgeConfig(), step=45, length=8, offsets=1, methods=("point", "grid2"))
    lines = capsys.readouterr().err.splitlines()
    assert any(line.startswith("error-vs-slope: point [") and "(0/2," in line for line in lines)
    assert any(line.startswith("error-vs-slope: grid2 [") and "(1/2," in line for line in lines)


def test_render_compare_names_each_method_while_it_runs(eager, tmp_path, capsys):
    from edgeaa.analysis.compare import SEED_METHODS

    scene = tmp_path / "tiny.json"
    scene.write_text(json.dumps(TINY_SCENE))
    assert main(["render", str(scene), "--compare", "-o", str(tmp_path / "c.png")]) == 0
    err = capsys.readouterr().err
    for stage in ("edgeaa paper", "Skia", *SEED_METHODS.values(), "exact area (shapely)"):
        assert f"render: {stage} [" in err, (stage, err)
    assert "render: figure " in err


def test_bench_and_stress_write_no_file_unless_asked(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    stress = ["stress", "--widths", "2", "--intensities", "4", "--plot-intensity-bits", "4"]
    assert main([*stress, "--quiet"]) == 0
    bench = ["bench", "--quick", "--edges", "3", "--repeats", "1", "--no-lines", "--quiet"]
    assert main(bench) == 0
    assert list(tmp_path.iterdir()) == []
    assert "wrote" not in capsys.readouterr().out
    assert main([*stress, "--quiet", "-o", "drift.png"]) == 0
    assert "wrote drift.png" in capsys.readouterr().out
    assert [p.name for p in tmp_path.iterdir()] == ["drift.png"]


def test_render_without_output_says_what_it_did_unless_quiet(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    scene = tmp_path / "tiny.json"
    scene.write_text(json.dumps(TINY_SCENE))
    said = "edgeaa render: rendered 20x14 px (model); give -o FILE.png to save it\n"
    for options, expected in (([], said), (["--quiet"], ""), (["--json"], "")):
        assert main(["render", str(scene), *options]) == 0
        assert capsys.readouterr().err == expected, options
    assert [p.name for p in tmp_path.iterdir()] == ["tiny.json"]
