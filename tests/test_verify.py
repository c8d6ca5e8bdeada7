"""`edgeaa verify`: sharded runs on the local pool and on a local Dask cluster, faults caught
and reported with reproducers that work, interrupted runs resumed without redoing shards."""

import dataclasses
import json
import os
import shlex
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from edgeaa.cli import main
from edgeaa.model import EdgeConfig, run_edge
from edgeaa.model.beat import COLUMN
from edgeaa.sim.verification import regress, shards
from edgeaa.sim.verification.scoreboard import beats_to_array, expected_beats
from edgeaa.sim.verification.workloads import random_sim_edges

DEFAULT = EdgeConfig()


def verify(capsys, *argv):
    """`edgeaa verify ARGV --json --quiet` in this process: (status, summary or None, stderr)."""
    status = main(["verify", *argv, "--json", "--quiet"])
    captured = capsys.readouterr()
    return status, json.loads(captured.out) if captured.out else None, captured.err


@pytest.fixture(autouse=True)
def no_cluster_from_the_environment(monkeypatch):
    """A scheduler address in the environment would send the local-pool runs elsewhere."""
    monkeypatch.delenv(regress.ADDRESS_VARIABLE, raising=False)


def records(directory) -> list[str]:
    return (directory / regress.RECORDS).read_text().splitlines(keepends=True)


def without_times(record: dict) -> dict:
    return {key: value for key, value in record.items() if "seconds" not in key}


# -- the plan and the model's side -----------------------------------------------------------


def test_shards_split_the_edges_and_their_seeds_differ():
    assert [shards.shard_size(10, 3, index) for index in range(3)] == [4, 3, 3]
    assert shards.default_shards(1) == 1 and shards.default_shards(100_000) == 50
    seeds = {shards.shard_seed(run, index) for run in range(3) for index in range(1000)}
    assert len(seeds) == 3000 and max(seeds) < 2**48
    plan = regress.Plan(DEFAULT, edges=7, shards=3, seed=5)
    assert [task.edges for task in plan.tasks()] == [3, 2, 2]
    assert list(plan.tasks()) == list(regress.Plan(DEFAULT, edges=7, shards=3, seed=5).tasks())


@pytest.mark.parametrize(
    "config",
    [
        DEFAULT,
        EdgeConfig(mode="pw"),
        EdgeConfig(mode="seg4", accumulator="truncated", coord_bits=15, subpixel_bits=8),
        EdgeConfig(mode="seg2", coord_bits=4, subpixel_bits=0, intensity_bits=4),
    ],
    ids=["default", "pw", "seg4-truncated-wide", "seg2-tiny"],
)
def test_beats_from_the_vectorized_model_equal_the_step_models(config):
    """The shards' expected beats (vectorized model, regrouped into columns) are the
    scoreboard's (step model), bad commands and empty windows included."""
    seed = 31
    edges = random_sim_edges(
        config, 400, seed, max_pixels=100, bad_fraction=0.05, clip_fraction=0.5
    )
    model = shards.model_stream(config, edges)
    beats, dropped = expected_beats(config, edges)
    assert np.array_equal(model.rows, beats_to_array(beats)), f"seed {seed}"
    assert model.dropped == dropped > 0, f"seed {seed}"
    assert (model.rows[:, COLUMN["lane1_valid"]] == 0).any() or config.mode == "pw"


# -- runs that pass --------------------------------------------------------------------------


def test_a_run_on_the_local_pool_passes(capsys):
    status, summary, err = verify(capsys, "--edges", "600", "--shards", "3", "--workers", "2")
    assert status == 0 and summary["passed"], err
    assert (summary["edges_checked"], summary["shards_done"], summary["shards_run"]) == (600, 3, 3)
    assert summary["beats_checked"] > 600 and summary["dropped_checked"] > 0
    assert summary["timed_edges_checked"] == 300 and summary["mismatches"] == []


def test_a_run_on_a_local_dask_cluster_gives_the_pools_records(capsys, tmp_path):
    """Two Dask workers on this machine (`--cluster local`): every shard's record (beats,
    clocks, bad commands) is the local pool's."""
    argv = ["--edges", "600", "--shards", "4", "--seed", "3", "--workers", "2"]
    status, summary, err = verify(
        capsys, *argv, "--cluster", "local", "--out", str(tmp_path / "dask")
    )
    assert status == 0 and summary["passed"] and summary["shards_run"] == 4, err
    status, _, err = verify(capsys, *argv, "--out", str(tmp_path / "pool"))
    assert status == 0, err

    def by_index(directory):
        rows = [without_times(json.loads(line)) for line in records(tmp_path / directory)]
        return sorted(rows, key=lambda record: record["index"])

    assert by_index("dask") == by_index("pool")


def test_the_scheduler_address_comes_from_the_environment(capsys, monkeypatch):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, dashboard_address=None, processes=True
    ) as cluster:
        monkeypatch.setenv(regress.ADDRESS_VARIABLE, cluster.scheduler_address)
        status, summary, err = verify(capsys, "--edges", "200", "--shards", "2")
        assert status == 0 and summary["passed"], err
        assert summary["cluster"] == cluster.scheduler_address


def test_the_amaranth_engine_checks_clocks_too(capsys):
    status, summary, err = verify(
        capsys, "--edges", "6", "--engine", "amaranth", "--workers", "0", "--mode", "seg2"
    )
    assert status == 0 and summary["passed"], err
    assert summary["timed_edges_checked"] == 6 and summary["clocks_checked"] > 6 * 30


def test_progress_shows_edges_per_second_and_time_left(monkeypatch):
    import io

    from edgeaa import progress

    monkeypatch.setattr(progress, "EVERY", 0.0)
    plan = regress.Plan(DEFAULT, edges=300, shards=3, seed=2)
    stream = io.StringIO()
    bar = progress.ProgressBar("verify", plan.edges, stream=stream, delay=0.0, unit="edges")
    runner = regress.open_runner(DEFAULT, "verilator", workers=0, cluster=None)
    summary = regress.run_plan(plan, runner, regress.ShardStore(None, plan.manifest()), bar)
    lines = stream.getvalue().splitlines()
    assert summary["passed"] and [line.split("(")[1].split(",")[0] for line in lines] == [
        "100/300",
        "200/300",
        "300/300",
    ]
    assert all(" edges/s" in line for line in lines) and " left)" in lines[0], lines


# -- faults are caught and reported with working reproducers ---------------------------------


def corrupt(kind: str, run):
    """The harness's view with one fault in the middle of the stream."""
    beats = run.beats.copy()
    middle = len(beats) // 2
    if kind == "value":
        beats[middle, 1 + COLUMN["lane0_value"]] ^= 1
    elif kind == "clock":
        beats[middle:, 0] += 1  # one beat late, and the rest after it
    elif kind == "lost":
        beats = np.delete(beats, middle, axis=0)
    elif kind == "errors":
        return dataclasses.replace(run, errors=run.errors + 1)
    return dataclasses.replace(run, beats=beats)


FAULTS = {  # kind: the stream it is injected into
    "value": "stalled",
    "lost": "stalled",
    "clock": "ready",
    "errors": "ready",
}


def inject(monkeypatch, kind: str, seed: int):
    original = shards.simulate

    def faulty(task, core, stream, edges):
        run = original(task, core, stream, edges)
        return corrupt(kind, run) if (task.seed, stream) == (seed, FAULTS[kind]) else run

    monkeypatch.setattr(shards, "simulate", faulty)


def model_writes(config, edge) -> list[tuple[int, int, int]]:
    return [(w.x, w.y, w.value) for w in run_edge(config, edge).writes]


def run_edge_reproducer(line: str) -> list[tuple[int, int, int]]:
    """Run the printed `edgeaa edge ...` line (the same entry point as `python -m edgeaa`)."""
    argv = shlex.split(line)
    assert argv[:2] == ["edgeaa", "edge"]
    proc = subprocess.run(
        [sys.executable, "-m", "edgeaa", *argv[1:]],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    return [tuple(int(v) for v in row.split()[:3]) for row in proc.stdout.splitlines()[1:]]


@pytest.mark.parametrize("kind", FAULTS)
def test_a_fault_is_caught_and_reported_with_working_reproducers(capsys, monkeypatch, kind):
    config = EdgeConfig(mode="seg2")
    plan = regress.Plan(config, edges=400, shards=2, seed=8)
    target = list(plan.tasks())[1]
    inject(monkeypatch, kind, target.seed)
    argv = ["--edges", "400", "--shards", "2", "--seed", "8", "--workers", "0", "--mode", "seg2"]
    status, summary, _ = verify(capsys, *argv)
    assert status == 1 and not summary["passed"]
    [found] = summary["mismatches"]  # shard 0 passed; the fault is reported once
    assert (found["kind"], found["shard"], found["seed"]) == (
        "clock" if kind == "clock" else "errors" if kind == "errors" else "beat",
        1,
        target.seed,
    )
    assert found["stream"] == FAULTS[kind] and str(target.seed) in found["reproduce_shard"]

    # The shard reproducer, with the fault still there, finds the same mismatch ...
    shard_argv = shlex.split(found["reproduce_shard"])
    assert shard_argv[:2] == ["edgeaa", "verify"]
    status, again, _ = verify(capsys, *shard_argv[2:], "--workers", "0")
    assert status == 1
    assert [{**m, "shard": 1} for m in again["mismatches"]] == summary["mismatches"]
    # ... and without it, the shard passes: the fault, not the core, was at fault.
    monkeypatch.undo()
    status, clean, _ = verify(capsys, *shard_argv[2:], "--workers", "0")
    assert status == 0 and clean["passed"]

    if kind == "errors":  # a count over the stream names no edge
        assert found["reproduce"] is None
        return
    edge = target.draw_edges()[found["edge"]]
    written = run_edge_reproducer(found["reproduce"])
    assert written == model_writes(config, edge)  # the edge command runs that very edge
    if kind == "value":  # it prints the model's pixel, not the one the faulty core gave
        model = shards.model_stream(config, target.streams()[0][2])
        assert found["beat"] == len(model.rows) // 2
        lane0 = [int(model.rows[found["beat"], COLUMN[f"lane0_{name}"]]) for name in "xy"]
        lane0.append(int(model.rows[found["beat"], COLUMN["lane0_value"]]))
        assert tuple(lane0) in written and (*lane0[:2], lane0[2] ^ 1) not in written


def test_a_crashing_worker_is_reported_and_not_recorded(capsys, monkeypatch, tmp_path):
    def broken(task, core, stream, edges):
        raise RuntimeError("harness failed (139): segmentation fault")

    monkeypatch.setattr(shards, "simulate", broken)
    status, summary, _ = verify(
        capsys, "--edges", "20", "--shards", "2", "--workers", "0", "--out", str(tmp_path)
    )
    assert status == 1 and [m["kind"] for m in summary["mismatches"]] == ["crash", "crash"]
    assert "segmentation fault" in summary["mismatches"][0]["message"]
    assert not (tmp_path / regress.RECORDS).exists()  # a rerun tries them again


# -- resuming --------------------------------------------------------------------------------


def test_a_rerun_skips_recorded_shards(capsys, monkeypatch, tmp_path):
    argv = ["--edges", "600", "--shards", "6", "--workers", "0", "--out", str(tmp_path)]
    status, first, _ = verify(capsys, *argv)
    assert status == 0 and first["shards_run"] == 6
    kept = records(tmp_path)
    # As if interrupted: three shards recorded, the fourth line cut short.
    (tmp_path / regress.RECORDS).write_text("".join(kept[:3]) + kept[3][:40])
    ran = []
    original = regress.check_shard

    def counted(task, core=None):
        ran.append(task.index)
        return original(task, core)

    monkeypatch.setattr(regress, "check_shard", counted)
    status, second, _ = verify(capsys, *argv)
    assert status == 0 and second["passed"]
    assert sorted(ran) == [3, 4, 5] and (second["shards_resumed"], second["shards_run"]) == (3, 3)
    lines = records(tmp_path)
    assert lines[:3] == kept[:3] and len(lines) == 6  # the cut line dropped, nothing redone
    assert [without_times(json.loads(x)) for x in sorted(lines)] == [
        without_times(json.loads(x)) for x in sorted(kept)
    ]
    assert {k: second[k] for k in ("edges_checked", "beats_checked", "clocks_checked")} == {
        k: first[k] for k in ("edges_checked", "beats_checked", "clocks_checked")
    }


def test_a_directory_of_another_run_is_refused(capsys, tmp_path):
    status, _, _ = verify(capsys, "--edges", "20", "--workers", "0", "--out", str(tmp_path))
    assert status == 0
    status, summary, err = verify(capsys, "--edges", "30", "--workers", "0", "--out", str(tmp_path))
    assert status == 2 and summary is None and err.count("\n") == 1
    assert "holds another run (edges 20 there, 30 here)" in err


def test_an_interrupted_run_finishes_on_rerun_without_redoing_shards(tmp_path):
    """Ctrl-C (SIGINT) to a real run: it stops with status 130, the finished shards stay
    recorded, and the same command finishes the rest."""
    command = [
        sys.executable,
        "-m",
        "edgeaa",
        "verify",
        "--edges",
        "40000",
        "--shards",
        "400",
        "--workers",
        "1",
        "--out",
        str(tmp_path),
        "--quiet",
    ]  # several seconds of shards after the first two: the interrupt lands mid-run
    env = {k: v for k, v in os.environ.items() if k != regress.ADDRESS_VARIABLE}
    # A shell's background job (CI may run in one) starts with SIGINT ignored, and Python then
    # keeps ignoring it: give the run the default disposition, as a terminal's Ctrl-C finds.
    proc = subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    deadline = time.monotonic() + 120
    while not (tmp_path / regress.RECORDS).exists() or len(records(tmp_path)) < 2:
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    kept = records(tmp_path)
    assert 2 <= len(kept) < 400
    rerun = subprocess.run(
        [*command, "--json"], capture_output=True, text=True, check=False, env=env, timeout=600
    )
    assert rerun.returncode == 0, rerun.stderr
    summary = json.loads(rerun.stdout)
    assert summary["passed"] and summary["shards_resumed"] == len(kept)
    assert summary["shards_run"] == 400 - len(kept) and summary["edges_checked"] == 40000
    assert records(tmp_path)[: len(kept)] == kept


# -- bad input -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--edges", "0"], "--edges must be in [1, 10**12], not 0"),
        (["--edges", "1" + "0" * 13], "--edges must be in [1, 10**12], not 10000000000000"),
        (["--edges", "9" * 5000], "must be an integer, not '99999"),
        (["--edges", "3", "--shards", "5"], "--shards must be in [1, --edges = 3], not 5"),
        (["--workers", "-1"], "--workers must be 0 (this process) to 256, not -1"),
        (["--workers", "65536"], "--workers must be 0 (this process) to 256, not 65536"),
        (["--shard-seed", "-1"], "must be a whole number below 2**64, not '-1'"),
        (["--shard-seed", str(1 << 64)], "must be a whole number below 2**64"),
        (["--shard-seed", "5", "--seed", "3"], "--shard-seed runs one shard"),
        (["--workers", "0", "--cluster", "local"], "--workers 0 runs in this process"),
        (["--engine", "icarus"], "invalid choice: 'icarus'"),
        (["--scenes"], "unrecognized arguments: --scenes"),
        (["--out", "/dev/null/run"], "--out /dev/null/run: Not a directory"),
    ],
)
def test_bad_input_is_one_line_with_status_2(capsys, argv, message):
    status, summary, err = verify(capsys, *argv)
    assert status == 2 and summary is None
    # (argparse reports an unknown option from the top-level parser: "edgeaa: error: ...")
    assert err.count("\n") == 1 and err.startswith("edgeaa") and message in err


# -- the long run ----------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize(
    ("config_argv", "edges"),
    [([], 1_000_000)]
    + [(["--mode", mode], 100_000) for mode in ("pw", "seg2", "seg4")]
    + [(["--accumulator", "truncated", "--coord-bits", "15", "--subpixel-bits", "8"], 100_000)],
    ids=["million-paper", "pw", "seg2", "seg4", "truncated-wide"],
)
def test_long_run_on_the_local_pool(capsys, config_argv, edges):
    status, summary, err = verify(capsys, "--edges", str(edges), "--seed", "2026", *config_argv)
    assert status == 0 and summary["passed"], summary and summary["mismatches"][:3]
    assert summary["edges_checked"] == edges
