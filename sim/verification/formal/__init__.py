# amaranth: UnusedElaboratable=no
"""Formal checks of the cores `edgeaa.hdl.LineCore` and `PolygonCore` with SymbiYosys (YoWASP
builds).

In: a configuration, the core (`LineCore` or `PolygonCore`), the check groups (`CHECKS`) to
assert, those to assume (sound once proven by induction), the covers (`COVERS`) and at most
one fault (`FAULTS`, to show a check can fail). `FormalHarness` wraps the core: every input
is free in every clock (``AnySeq``: the ``edges`` payload and valid, the ``clip`` window, the
output's ready and, by default, the reset), with no input assumption at all. It reads only
the observation attributes `EdgeSetupUnit` and the steppers expose for verification, so a
rename there is an AttributeError when the harness is built, never a vacuous proof. Out: a
`FormalResult` per proof (`run_proof`; `PROOFS` for the line core, `DELTA_PROOFS` for the
polygon core, `FAST_PROOFS` for it with the deep stepper, `DELTAS_FAST`), whose ``failed``
lists the failing properties and induction helpers.

Files: `spec` (the model-side specification: fold, window, bank invariants, one column in
full width; `implies`), `harness` (`FormalHarness`), one module per property family
(`stream`, also the one hold rule of every proof, `count`, `bounds`, `pipeline` for
``pipe``, ``beat`` and ``minor``, `deltas` for the polygon core, `covers`), `run` (`Proof`,
`PROOFS`, `DELTA_PROOFS`, `FAST_PROOFS`, `run_proof`, `main`) and the tile stages: `tile`
(`TileHarness`, `TILE_PROOFS`, `run_tile_proof`), `accumulator` and `resolve` (their check
groups and invariants), `tile_common` (what those share). `python -m
edgeaa.sim.verification.formal [proof ...]` runs proofs.

What each check group and cover states, the white-box helpers the inductions need, the
faults, and the proofs' run times: docs/hardware.md, "Formal proofs" and "The harness, its
check groups and faults".
"""

from __future__ import annotations

from .count import capacity
from .harness import CHECKS, COVERS, FAULTS, FormalHarness
from .run import (
    DELTA_PROOFS,
    FAST_PROOFS,
    PROOFS,
    FormalError,
    FormalResult,
    FormalToolNotFoundError,
    Proof,
    find_tools,
    harness_rtlil,
    main,
    run_proof,
    sby_script,
)

__all__ = [
    "CHECKS",
    "COVERS",
    "FAST_PROOFS",
    "DELTA_PROOFS",
    "FAULTS",
    "PROOFS",
    "FormalError",
    "FormalHarness",
    "FormalResult",
    "FormalToolNotFoundError",
    "Proof",
    "capacity",
    "find_tools",
    "harness_rtlil",
    "main",
    "run_proof",
    "sby_script",
]
