"""`edgeaa verify`: sharded runs on the local pool and on a local Dask cluster, faults caught
and reported with reproducers that work, interrupted runs resumed without redoing shards."""

import dataclasses
import hashlib
import json
import os
import shlex
import signal
import subprocess
import sys
import time
import tracemalloc

import numpy as np
import pytest

from edgeaa.cli import main
from edgeaa.model import EdgeConfig, run_edge
from edgeaa.model.beat import COLUMN
from edgeaa.sim.verification import records, regress, scene_shards, shards
from edgeaa.sim.verification.scoreboard import beats_to_array, expected_beats
from edgeaa.sim.verification.workloads import random_scene, random_sim_edges

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


def record_lines(directory) -> list[str]:
    return (directory / records.RECORDS).read_text().splitlines(keepends=True)


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
        rows = [without_times(json.loads(line)) for line in record_lines(tmp_path / directory)]
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
    """In this process, progress after each piece of a shard (pieces of 30 edges here) and
    after each shard, with the rate and the time left."""
    import io

    from edgeaa import progress

    monkeypatch.setattr(progress, "EVERY", 0.0)
    monkeypatch.setattr(shards, "CHUNK_EDGES", 30)
    plan = regress.Plan(DEFAULT, edges=300, shards=3, seed=2)
    stream = io.StringIO()
    bar = progress.ProgressBar("verify", plan.edges, stream=stream, delay=0.0, unit="edges")
    runner = regress.open_runner(DEFAULT, "verilator", workers=0, cluster=None)
    summary = regress.run_plan(plan, runner, records.ShardStore(None, plan.manifest()), bar)
    lines = stream.getvalue().splitlines()
    pieces = [30, 50, 80, 100, 100]  # streams of 50 edges: pieces of 30 and 20, then the shard
    done = [int(line.split("(")[1].split("/")[0]) for line in lines]
    assert summary["passed"] and done == [
        *pieces,
        *(100 + x for x in pieces),
        *(200 + x for x in pieces),
    ]
    assert all(" edges/s" in line for line in lines) and " left)" in lines[0], lines


def test_a_local_pool_shows_progress_inside_a_shard():
    """A worker of the local pool reports each piece of its shard (two pieces of CHUNK_EDGES)."""
    edges = 2 * shards.CHUNK_EDGES
    plan = regress.Plan(EdgeConfig(mode="seg2"), edges=edges, shards=1, seed=1)  # short edges
    seen = []
    runner = regress.open_runner(plan.config, "verilator", workers=1, cluster=None)
    try:
        summary = regress.run_plan(
            plan,
            runner,
            records.ShardStore(None, plan.manifest()),
            progress=lambda *args: seen.append(args[0]),
        )
    finally:
        runner.close()
    assert summary["passed"] and seen == [edges // 2, edges, edges]


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

    def faulty(task, core, stream, edges, part=0):
        run = original(task, core, stream, edges, part)
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
    def broken(task, core, stream, edges, part=0):
        raise RuntimeError("harness failed (139): segmentation fault")

    monkeypatch.setattr(shards, "simulate", broken)
    status, summary, _ = verify(
        capsys, "--edges", "20", "--shards", "2", "--workers", "0", "--out", str(tmp_path)
    )
    assert status == 1 and [m["kind"] for m in summary["mismatches"]] == ["crash", "crash"]
    assert "segmentation fault" in summary["mismatches"][0]["message"]
    assert not (tmp_path / records.RECORDS).exists()  # a rerun tries them again


# -- scenes through the pipeline ------------------------------------------------------------


def scene_seeds(scenes: int, shards: int, seed: int = 1) -> list[int]:
    """The scene seeds of a run's shards, in order, as the plan makes them."""
    plan = regress.ScenePlan(DEFAULT, scenes, shards, seed)
    return [s for task in plan.tasks() for s in task.seeds()]


def test_random_scenes_are_seeded_and_span_tiles():
    """The same seed draws the same scene; over 100 seeds, scenes wider and taller than a
    default tile (64 x 32), both fill rules, polygons of one and of two contours."""
    assert random_scene(DEFAULT, 5) == random_scene(DEFAULT, 5) != random_scene(DEFAULT, 6)
    scenes = [random_scene(DEFAULT, seed) for seed in range(100)]
    assert any(s.width > 128 for s in scenes) and any(s.height > 64 for s in scenes)
    polygons = [p for s in scenes for p in s.polygons]
    assert {p.fill_rule for p in polygons} == {"nonzero", "evenodd"}
    assert {len(p.contours) for p in polygons} == {1, 2}
    assert len({p.intensity for p in polygons}) > 5


def test_a_scene_run_checks_every_pixel_and_resumes(capsys, monkeypatch, tmp_path):
    """4 scenes in 2 shards: every pixel of every scene checked; a rerun after the second
    shard's record was cut short runs that shard alone and gives the same totals."""
    argv = ["--scenes", "4", "--shards", "2", "--workers", "0", "--out", str(tmp_path)]
    status, first, err = verify(capsys, *argv)
    assert status == 0 and first["passed"] and first["mismatches"] == [], err
    scenes = [random_scene(DEFAULT, seed) for seed in scene_seeds(4, 2)]
    assert (first["scenes_checked"], first["shards_run"]) == (4, 2)
    assert first["pixels_checked"] == sum(s.width * s.height for s in scenes)
    assert first["clocks_checked"] > 4 * 2048 and first["failed_scenes_checked"] == 0
    kept = record_lines(tmp_path)
    (tmp_path / records.RECORDS).write_text(kept[0] + kept[1][:30])
    ran = []
    original = scene_shards.check_scenes

    def counted(task, core=None, report=None):
        ran.append(task.index)
        return original(task, core, report)

    monkeypatch.setattr(scene_shards, "check_scenes", counted)
    status, second, err = verify(capsys, *argv)
    assert status == 0 and second["passed"] and "line 2 was cut short" in err
    assert ran == [1] and (second["shards_resumed"], second["shards_run"]) == (1, 1)
    for key in ("scenes_checked", "pixels_checked", "clocks_checked"):
        assert second[key] == first[key], key


@pytest.mark.parametrize("kind", ["pixel", "hang"])
def test_a_scene_fault_is_caught_and_names_the_scene(capsys, monkeypatch, tmp_path, kind):
    """A harness result with one pixel flipped (or a hang) in the third scene: the run fails
    and names that scene's seed and the pixel; the scene's reproducer finds it again, and
    passes once the fault is gone; the mismatch's record reads back on a rerun."""
    from edgeaa.sim.simulators import pipeline_harness

    target = scene_seeds(4, 2)[2]
    drawn, original = [], pipeline_harness.run

    def drawing(config, seed):
        drawn.append(seed)
        return random_scene(config, seed)

    def faulty(tile, commands, **options):
        run = original(tile, commands, **options)
        if drawn[-1] != target:
            return run
        if kind == "hang":
            raise pipeline_harness.PipelineHang("the pipeline gave 0 of 2048 pixels")
        pixels = run.pixels.copy()
        pixels[0, pipeline_harness.PIXEL_COLUMNS.index("value")] ^= 1  # image pixel (0, 0)
        return dataclasses.replace(run, pixels=pixels)

    monkeypatch.setattr(scene_shards, "random_scene", drawing)
    monkeypatch.setattr(pipeline_harness, "run", faulty)
    argv = ["--scenes", "4", "--shards", "2", "--workers", "0", "--out", str(tmp_path)]
    status, summary, _ = verify(capsys, *argv)
    assert status == 1 and not summary["passed"]
    [found] = summary["mismatches"]
    assert (found["kind"], found["scene"], found["shard"]) == (kind, target, 1)
    assert f"scene seed {target}" in found["message"]
    if kind == "pixel":
        assert (found["x"], found["y"]) == (0, 0) and "1 of" in found["message"]
        assert summary["wrong_pixels_checked"] == 1
    assert summary["failed_scenes_checked"] == 1
    status, resumed, _ = verify(capsys, *argv)  # the record, mismatch included, reads back
    assert status == 1 and resumed["shards_run"] == 0
    assert resumed["mismatches"] == summary["mismatches"]

    scene_argv = shlex.split(found["reproduce"])
    assert scene_argv[:2] == ["edgeaa", "verify"]
    status, again, _ = verify(capsys, *scene_argv[2:], "--workers", "0")
    assert status == 1 and again["mismatches"][0]["scene"] == target
    assert again["mismatches"][0]["message"] == found["message"]
    monkeypatch.undo()
    status, clean, _ = verify(capsys, *scene_argv[2:], "--workers", "0")
    assert status == 0 and clean["passed"] and clean["scenes_checked"] == 1


def test_a_scene_records_schema_holds_its_own_records():
    task = next(regress.ScenePlan(DEFAULT, 4, 2, 3).tasks())
    manifest = regress.ScenePlan(DEFAULT, 4, 2, 3).manifest()
    crash = regress.crash_result(task, RuntimeError("x"))
    mismatch = crash["mismatches"][0] | {"scene": task.seed}
    record = {key: value for key, value in crash.items() if key != "crashed"}
    assert records.record_error(record | {"mismatches": [mismatch] * 6}, manifest) is None
    assert records.record_error(record | {"mismatches": [mismatch] * 7}, manifest)
    assert "the plan's" in records.record_error(record | {"seed": task.seed + 1}, manifest)


# -- resuming --------------------------------------------------------------------------------


def test_a_rerun_skips_recorded_shards(capsys, monkeypatch, tmp_path):
    argv = ["--edges", "600", "--shards", "6", "--workers", "0", "--out", str(tmp_path)]
    status, first, _ = verify(capsys, *argv)
    assert status == 0 and first["shards_run"] == 6
    kept = record_lines(tmp_path)
    # As if interrupted: three shards recorded, the fourth line cut short.
    (tmp_path / records.RECORDS).write_text("".join(kept[:3]) + kept[3][:40])
    ran = []
    original = shards.check_shard

    def counted(task, core=None, chunk=None, report=None):
        ran.append(task.index)
        return original(task, core, chunk, report)

    monkeypatch.setattr(shards, "check_shard", counted)
    status, second, err = verify(capsys, *argv)
    assert status == 0 and second["passed"]
    assert f"{tmp_path / records.RECORDS} line 4 was cut short" in err and err.count("\n") == 1
    assert sorted(ran) == [3, 4, 5] and (second["shards_resumed"], second["shards_run"]) == (3, 3)
    lines = record_lines(tmp_path)
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
    status, summary, err = verify(capsys, "--scenes", "1", "--workers", "0", "--out", str(tmp_path))
    assert status == 2 and summary is None and err.count("\n") == 1
    assert "holds a run of edges, not of scenes: give another --out" in err


def test_an_interrupted_run_finishes_on_rerun_without_redoing_shards(tmp_path):
    """Ctrl-C (SIGINT) to a real run: it stops with status 130, the finished shards stay
    recorded, and the same command finishes the rest."""
    command = [
        sys.executable,
        "-m",
        "edgeaa",
        "verify",
        "--edges",
        "8000",
        "--shards",
        "80",
        "--workers",
        "1",
        "--out",
        str(tmp_path),
        "--quiet",
    ]  # seconds of shards after the first two (0.05 s a shard): the interrupt lands mid-run
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
    while not (tmp_path / records.RECORDS).exists() or len(record_lines(tmp_path)) < 2:
        assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    kept = record_lines(tmp_path)
    assert 2 <= len(kept) < 80
    rerun = subprocess.run(
        [*command, "--json"], capture_output=True, text=True, check=False, env=env, timeout=600
    )
    assert rerun.returncode == 0, rerun.stderr
    summary = json.loads(rerun.stdout)
    assert summary["passed"] and summary["shards_resumed"] == len(kept)
    assert summary["shards_run"] == 80 - len(kept) and summary["edges_checked"] == 8000
    assert record_lines(tmp_path)[: len(kept)] == kept


# -- records it did not write ---------------------------------------------------------------

RECORDED = ["--edges", "30", "--shards", "3", "--seed", "6", "--workers", "0"]


@pytest.fixture(scope="module")
def recorded_run(tmp_path_factory):
    """The record of a finished run of `RECORDED`: run.json and three lines of shards.jsonl."""
    directory = tmp_path_factory.mktemp("recorded")
    assert main(["verify", *RECORDED, "--out", str(directory), "--quiet", "--json"]) == 0
    return {name: (directory / name).read_bytes() for name in (records.MANIFEST, records.RECORDS)}


def refused(capsys, directory, name: str, where: str):
    """Rerun `RECORDED` on `directory`: refused in one line naming `where` in file `name`,
    with the hint, and nothing there changed."""
    before = {p.name: p.read_bytes() for p in directory.iterdir() if p.is_file()}
    status, summary, err = verify(capsys, *RECORDED, "--out", str(directory))
    assert status == 2 and summary is None and err.count("\n") == 1, err
    assert err.startswith(f"edgeaa verify: error: {directory / name}{where} "), err
    assert err.endswith(f"; use a fresh --out folder or delete {directory}\n"), err
    assert {p.name: p.read_bytes() for p in directory.iterdir() if p.is_file()} == before
    return err


@pytest.mark.parametrize(
    ("content", "what"),
    [
        (b"[]", "is not a run record"),
        (b'"a string"', "is not a run record"),
        (b"null", "is not a run record"),
        (b"[" * 30_000 + b"]" * 30_000, "nests too deeply"),
        (b'{"format": 1, "config": ', "is not JSON"),
        (b"\xff\xfe{}", "is not UTF-8 text"),
        (b" " * (records.MAX_MANIFEST + 1), "is larger than 65,536 bytes"),
        (None, "is a directory"),
    ],
    ids=["list", "string", "null", "deep", "truncated", "not-utf8", "huge", "directory"],
)
def test_a_run_record_it_did_not_write_is_refused(capsys, tmp_path, content, what):
    if content is None:
        (tmp_path / records.MANIFEST).mkdir()
    else:
        (tmp_path / records.MANIFEST).write_bytes(content)
    assert what in refused(capsys, tmp_path, records.MANIFEST, "")
    assert not (tmp_path / records.RECORDS).exists()


def damaged_manifest(manifest: dict, how: str) -> dict:
    if how == "config":
        return {**manifest, "config": [[[1]]]}
    if how == "format":  # the format before the workload named its pieces
        workload = {k: v for k, v in manifest["workload"].items() if k != "chunk_edges"}
        return {**manifest, "format": 1, "workload": workload}
    if how == "nested":
        return {**manifest, "edges": {"deep": [[[[30]]]]}}
    return {**manifest, "workload": {**manifest["workload"], "max_pixels": [[16], 48]}}


@pytest.mark.parametrize("how", ["config", "nested", "workload", "format"])
def test_a_run_record_of_the_wrong_shape_is_refused(capsys, tmp_path, recorded_run, how):
    manifest = json.loads(recorded_run[records.MANIFEST])
    (tmp_path / records.MANIFEST).write_text(json.dumps(damaged_manifest(manifest, how)))
    refused(capsys, tmp_path, records.MANIFEST, "")


def damage(record: dict, how: str):
    """A shard's record (a line of shards.jsonl) damaged as `how` says, or its bytes."""
    changes = {
        "beats-text": {"beats": "many"},
        "clocks-negative": {"clocks": -1},
        "clocks-bool": {"clocks": True},
        "seconds-nan": {"seconds": float("nan")},
        "index-outside": {"index": 3},
        "index-nested": {"index": [[[0]]]},
        "seed-other": {"seed": record["seed"] + 1},
        "edges-other": {"edges": record["edges"] + 1},
        "mismatches-text": {"mismatches": "none"},
        "mismatch-empty": {"mismatches": [{}]},
    }
    if how in changes:
        return {**record, **changes[how]}
    if how == "missing-field":
        return {key: value for key, value in record.items() if key != "clocks"}
    return {"object": {}, "list": [], "number": 5}[how]


LINE_DAMAGE = [
    "beats-text",
    "clocks-negative",
    "clocks-bool",
    "seconds-nan",
    "index-outside",
    "index-nested",
    "seed-other",
    "edges-other",
    "mismatches-text",
    "mismatch-empty",
    "missing-field",
    "object",
    "list",
    "number",
]


@pytest.mark.parametrize("how", LINE_DAMAGE)
def test_a_damaged_shard_record_is_named_and_refused(capsys, tmp_path, recorded_run, how):
    (tmp_path / records.MANIFEST).write_bytes(recorded_run[records.MANIFEST])
    lines = recorded_run[records.RECORDS].splitlines(keepends=True)
    lines[1] = json.dumps(damage(json.loads(lines[1]), how)).encode() + b"\n"
    (tmp_path / records.RECORDS).write_bytes(b"".join(lines))
    refused(capsys, tmp_path, records.RECORDS, " line 2")


@pytest.mark.parametrize(
    ("line", "what"),
    [
        (lambda line: line[:40] + b"\n", "is not JSON"),  # cut short, then a newline
        (lambda line: b"\xff" + line, "is not UTF-8 text"),
        (lambda line: b"[" * 30_000 + b"\n", "nests too deeply"),
        (lambda line: b" " * records.MAX_LINE + line, "is longer than 65,536 bytes"),
        (lambda line: b"\n", "is not JSON"),
    ],
    ids=["truncated", "not-utf8", "deep", "huge", "empty"],
)
def test_a_damaged_line_is_named_and_refused(capsys, tmp_path, recorded_run, line, what):
    (tmp_path / records.MANIFEST).write_bytes(recorded_run[records.MANIFEST])
    lines = recorded_run[records.RECORDS].splitlines(keepends=True)
    lines[1] = line(lines[1])
    (tmp_path / records.RECORDS).write_bytes(b"".join(lines))
    assert what in refused(capsys, tmp_path, records.RECORDS, " line 2")


def test_a_shard_recorded_twice_and_a_records_directory_are_refused(capsys, tmp_path, recorded_run):
    (tmp_path / records.MANIFEST).write_bytes(recorded_run[records.MANIFEST])
    lines = recorded_run[records.RECORDS].splitlines(keepends=True)
    (tmp_path / records.RECORDS).write_bytes(b"".join([*lines, lines[0]]))
    err = refused(capsys, tmp_path, records.RECORDS, " line 4")
    assert "records shard 0 again" in err
    (tmp_path / records.RECORDS).unlink()
    (tmp_path / records.RECORDS).mkdir()
    assert "is a directory" in refused(capsys, tmp_path, records.RECORDS, "")


def test_its_own_record_passes_the_schema(recorded_run):
    """Every field `check_shard` writes, a mismatch's included, is one the schema knows."""
    manifest = json.loads(recorded_run[records.MANIFEST])
    record = json.loads(recorded_run[records.RECORDS].splitlines()[0])
    task = next(regress.Plan(DEFAULT, edges=30, shards=3, seed=6).tasks())
    crash = regress.crash_result(task, RuntimeError("x"))
    mismatch = crash["mismatches"][0]
    assert records.record_error(record, manifest) is None
    assert records.record_error({**record, "mismatches": [mismatch] * 6}, manifest) is None
    assert records.record_error({**record, "mismatches": [mismatch] * 7}, manifest)


def test_a_long_record_is_read_in_bounded_memory(tmp_path):
    """Resuming keeps the finished shards' indices and totals, not their records: 20,000
    lines read in well under a megabyte (the records held would take about 25 MB), and the
    summary lists at most MAX_LISTED mismatches and counts them all."""
    count = 20_000
    plan = regress.Plan(DEFAULT, edges=2 * count, shards=count, seed=4)
    (tmp_path / records.MANIFEST).write_text(json.dumps(plan.manifest()))
    mismatch = regress.crash_result(next(plan.tasks()), RuntimeError("x"))["mismatches"][0]
    with open(tmp_path / records.RECORDS, "w") as file:
        for task in plan.tasks():
            found = [{**mismatch, "shard": task.index}] if task.index % 100 == 7 else []
            record = {"index": task.index, "seed": task.seed, "edges": task.edges, "beats": 9}
            record.update(clocks=12, dropped=0, timed_edges=1, sim_seconds=0.1, seconds=0.2)
            file.write(json.dumps({**record, "mismatches": found}) + "\n")
    tracemalloc.start()
    try:
        store = records.ShardStore(tmp_path, plan.manifest())
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1_000_000, peak
    assert len(store.finished) == count and count - 1 in store.finished
    assert count not in store.finished and store.finished.above == set()
    summary = regress.summarize(
        plan,
        store.totals,
        records.Totals(store.totals.summed),
        records.Totals(store.totals.summed),
        count,
        1,
    )
    assert (summary["edges_checked"], summary["beats_checked"]) == (2 * count, 9 * count)
    assert summary["mismatch_count"] == count // 100 and not summary["passed"]
    assert [m["shard"] for m in summary["mismatches"]] == list(range(7, count, 100))[:100]
    assert records.MAX_LISTED == 100


# -- a shard in bounded pieces ---------------------------------------------------------------


def test_random_edges_are_those_of_before_and_chunks_are_one_draw():
    """`random_sim_edges` draws what it drew before it was a generator's first edges (the
    hashes are of the old code's draws), and a shard's pieces are its single draw."""
    tiny = EdgeConfig(mode="seg2", coord_bits=4, subpixel_bits=0, intensity_bits=4)
    for config, options, digest in [
        (DEFAULT, {"max_pixels": 48, "bad_fraction": 0.02, "clip_fraction": 0.5}, "d5e1d6ce"),
        (tiny, {"max_pixels": 200, "bad_fraction": 0.1}, "5cc42762"),
    ]:
        edges = random_sim_edges(config, 1000, 12345, **options)
        assert hashlib.sha256(repr(edges).encode()).hexdigest()[:8] == digest
    for engine, count, size in [("verilator", 23, 4), ("verilator", 1, 3), ("amaranth", 10, 3)]:
        task = shards.ShardTask(0, 77, count, DEFAULT, engine)
        pieces = list(task.chunks(size))
        assert [edge for *_, edges in pieces for edge in edges] == task.draw_edges()
        assert all(0 < len(edges) <= size for *_, edges in pieces)
        for name, lo, edges in task.streams():
            mine = [piece for piece in pieces if piece[0] == name]
            assert [part for _, part, _, _ in mine] == list(range(len(mine)))
            assert mine[0][2] == lo and sum(len(p[3]) for p in mine) == len(edges)


def peak_bytes(task, core, chunk) -> tuple[int, dict]:
    tracemalloc.start()
    try:
        result = shards.check_shard(task, core, chunk)
        return tracemalloc.get_traced_memory()[1], result
    finally:
        tracemalloc.stop()


def test_a_shards_memory_is_that_of_one_chunk():
    """A shard of eight pieces (four a stream) peaks at about one piece's memory (Python and
    numpy allocations, traced), not four; its edges, beats and bad commands are those of one
    piece a stream."""
    core = shards.CompiledCore.build(DEFAULT)
    size = 250
    task = shards.ShardTask(0, 2027, 8 * size, DEFAULT)
    assert task.max_pixels == 200  # long edges: the most beats an edge
    one_chunk, _ = peak_bytes(dataclasses.replace(task, edges=2 * size), core, size)
    chunked, result = peak_bytes(task, core, size)
    whole, single = peak_bytes(task, core, 4 * size)
    assert chunked < 1.2 * one_chunk and whole > 2 * one_chunk, (one_chunk, chunked, whole)
    assert result["mismatches"] == single["mismatches"] == []
    for key in ("edges", "beats", "dropped", "timed_edges"):
        assert result[key] == single[key], key
    assert shards.CHUNK_EDGES == 10_000  # the size a shard uses


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
        (["--scenes", "3", "--edges", "5"], "--edges and --scenes are separate runs"),
        (["--scenes", "0"], "--scenes must be in [1, 10**9], not 0"),
        (["--scenes", "2", "--engine", "amaranth"], "--engine amaranth is for edges"),
        (["--scenes", "3", "--shards", "4"], "--shards must be in [1, --scenes = 3], not 4"),
        (["--scenes", "10001", "--shards", "2"], "a shard holds at most 5,000 scenes"),
        (["--scenes", "5001", "--shard-seed", "7"], "--scenes 5,001 for one shard"),
        (["--out", "/dev/null/run"], "--out /dev/null/run: Not a directory"),
        (["--edges", "100000000", "--shards", "1"], "a shard holds at most 1,000,000 edges"),
        (["--edges", "3000000", "--shards", "2"], "give --shards >= 3"),
        (["--shard-seed", "5", "--edges", "1000001"], "--edges 1,000,001 for one shard"),
    ],
)
def test_bad_input_is_one_line_with_status_2(capsys, argv, message):
    status, summary, err = verify(capsys, *argv)
    assert status == 2 and summary is None
    # (argparse reports an unknown option from the top-level parser: "edgeaa: error: ...")
    assert err.count("\n") == 1 and err.startswith("edgeaa") and message in err


def test_help_says_what_exists(capsys):
    """The pipeline exists (hdl/pipeline.py) and --scenes checks it: --help says so, and that
    a run checks edges or scenes, not both."""
    with pytest.raises(SystemExit) as exit_:
        main(["verify", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert exit_.value.code == 0 and "does not exist" not in text
    assert "hdl/pipeline.py" in text and "--engine verilator" in text
    assert "not there yet" not in text and "--scenes N" in text
    assert "give --edges or --scenes" in text


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
