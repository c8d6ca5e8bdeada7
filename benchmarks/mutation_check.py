"""A seeded mutation check: does the default test run catch realistic one-line bugs?

Not a test: each mutant is one line of the model, the column arithmetic, the tile accumulator
and resolve, the stepper, the deltas unit or the renderer changed into a plausible bug (an
off-by-one compare, a dropped term, a wrong rounding, a swapped sign). The script copies HEAD
(`git archive`) into a temporary folder, applies the change (the line must occur exactly
once), checks that the mutated module still imports, and runs the default-run test files that
cover it (`TESTS`: the project's addopts, so no `-m slow` or `-m formal` test) with `-x` in
that copy. A mutant is caught when pytest reports a failed test; survivors are findings.

The picker takes one candidate per file (seeded), then fills up to --count round-robin.
Usage: python benchmarks/mutation_check.py [--seed 25] [--count 10] [--timeout 900] [--list]
"""

from __future__ import annotations

import argparse
import random
import re
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# The model against independent references: the line writes' error bound (test_bounds), the
# deltas' column and row sums, the exact image, and the piece ends (test_accumulation).
MODEL_TESTS = ("tests/test_bounds.py", "tests/test_accumulation.py")
# Which default-run test files cover each mutated file (the most relevant one to three).
TESTS = {
    "model/step.py": MODEL_TESTS,
    "model/edge.py": MODEL_TESTS,
    "model/column.py": MODEL_TESTS,
    "hdl/accumulator.py": ("tests/test_tile_hw.py",),
    "hdl/accumulator_cells.py": ("tests/test_tile_hw.py",),
    "hdl/resolve.py": ("tests/test_tile_hw.py",),
    "hdl/stepper.py": ("tests/test_core_equivalence.py",),
    "hdl/column_loop.py": ("tests/test_core_equivalence.py",),
    "hdl/deltas.py": ("tests/test_core_deltas.py",),
    "render/render.py": ("tests/test_render.py", "tests/test_accumulation.py"),
}


@dataclass(frozen=True)
class Mutant:
    path: str
    line: str  # the exact source line (without its newline)
    replacement: str
    what: str


def m(path: str, line: str, replacement: str, what: str) -> Mutant:
    return Mutant(path, line, replacement, what)


CANDIDATES = (
    m("model/step.py",
      '        hs = a.check("height", he - (st.ifix if step.row_step else 0))',
      '        hs = a.check("height", he)',
      "dropped term: next piece start ignores the row step"),
    m("model/step.py",
      "        last = column == st.columns - 1 and p.last_partial",
      "        last = column == st.columns and p.last_partial",
      "off-by-one: the last partial column never seen"),
    m("model/edge.py",
      "    row0 = floor_div(2 * num + den, 2 * den)  # row whose span [y - 1/2, y + 1/2) holds vc",
      "    row0 = floor_div(2 * num - den, 2 * den)  # row whose span [y - 1/2, y + 1/2) holds vc",
      "+ turned into -: first row rounds the wrong way"),
    m("model/edge.py",
      "    start_clip = folded.c0 < lo",
      "    start_clip = folded.c0 <= lo",
      "off-by-one compare: a vertex on the clip edge counted as clipped"),
    m("model/edge.py",
      "    khq, khr = _divmod(i_d * f.dv << (F - 1), du)",
      "    khq, khr = _divmod(i_d * f.dv << (F - 2), du)",
      "wrong shift: K/4 in place of K/2"),
    m("model/column.py",
      "    row_step = jsum >= st.ifix",
      "    row_step = jsum > st.ifix",
      "off-by-one compare: row step at J > 1, not J >= 1"),
    m("model/column.py",
      "    rounded = (area + (1 << (F - 1))) >> F",
      "    rounded = area >> F",
      "wrong rounding: truncates the intensity offset"),
    m("model/column.py",
      "    a_mid = _clamp(a, total + band - a_up - a_low, band)",
      "    a_mid = _clamp(a, total - a_up - a_low, band)",
      "dropped term: y-major middle cell without its band"),
    m("model/column.py",
      "    carry = (jr + st.khr) >= st.du",
      "    carry = (jr + st.khr) > st.du",
      "off-by-one compare: piece end misses the remainder carry"),
    m("hdl/accumulator_cells.py",
      "    inside = (ty >= 0) & (ty < tile.height) & (tx < tile.width)",
      "    inside = (ty > 0) & (ty < tile.height) & (tx < tile.width)",
      "off-by-one compare: the tile's first row dropped"),
    m("hdl/accumulator_cells.py",
      "    base = Mux(c_valid & (c_addr == b_addr), c_sum, Mux(unit._clear, 0, rd.data))",
      "    base = Mux(unit._clear, 0, rd.data)",
      "dropped forwarding: back-to-back deltas to one cell lose one"),
    m("hdl/accumulator.py",
      "            new_lo, new_hi = Mux(cell.x < lo, cell.x, lo), Mux(cell.x > hi, cell.x, hi)",
      "            new_lo, new_hi = Mux(cell.x > lo, cell.x, lo), Mux(cell.x > hi, cell.x, hi)",
      "swapped compare: the scan span's left end"),
    m("hdl/resolve.py",
      '        qs = [Mux(s2.d == 0, 0, (getattr(s2, f"cov{n}") + (1 << (F - 1))) >> F)'
      ' for n in lanes]',
      '        qs = [Mux(s2.d == 0, 0, getattr(s2, f"cov{n}") >> F) for n in lanes]',
      "wrong rounding: coverage truncated"),
    m("hdl/resolve.py",
      '                    Mux(getattr(last, f"zero{lane}"), below,'
      ' below + signed_quot + neg)[:bits]',
      '                    Mux(getattr(last, f"zero{lane}"), below, below + signed_quot)[:bits]',
      "dropped term: the negative quotient's correction"),
    m("hdl/resolve.py",
      "        mag = Mux(s < 0, -s, s)",
      "        mag = s",
      "dropped abs: non-zero rule on a negative winding"),
    m("hdl/column_loop.py",
      "            sums[1].eq(jq + self.kq + 1),",
      "            sums[1].eq(jq + self.kq),",
      "dropped term: the remainder's carry into J"),
    m("hdl/stepper.py",
      "            lane1_x.eq(Mux(lane1_below, c.x_ - c.row_dx_, c.x_ + c.row_dx_)),",
      "            lane1_x.eq(Mux(lane1_below, c.x_ + c.row_dx_, c.x_ - c.row_dx_)),",
      "swapped operands: the neighbour's x on the wrong side"),
    m("hdl/deltas.py",
      '            regs["hs"].eq(Mux(row_step, he - st.ifix, he)),',
      '            regs["hs"].eq(he),',
      "dropped term: next piece start ignores the row step"),
    m("hdl/deltas.py",
      '            regs["adj"].eq(regs["adj"] - row_step),',
      '            regs["adj"].eq(regs["adj"] + row_step),',
      "- turned into +: P1's row offset drifts the wrong way"),
    m("render/render.py",
      "    pts += 0.5",
      "    pts += 0.0",
      "wrong rounding: vertices truncated to the sub-pixel grid"),
    m("render/render.py",
      "    lo_x = np.floor_divide(np.minimum(coords[:, 0], coords[:, 2]), S) - WRITE_MARGIN - ox",
      "    lo_x = np.floor_divide(np.minimum(coords[:, 0], coords[:, 2]), S) + WRITE_MARGIN - ox",
      "- turned into +: write boxes too narrow, edges culled wrongly"),
)  # fmt: skip


def pick(seed: int, count: int) -> list[Mutant]:
    """One candidate per file first (seeded order), then round-robin until `count`."""
    rng = random.Random(seed)
    by_file: dict[str, list[Mutant]] = {}
    for mutant in CANDIDATES:
        by_file.setdefault(mutant.path, []).append(mutant)
    for group in by_file.values():
        rng.shuffle(group)
    chosen: list[Mutant] = []
    while len(chosen) < min(count, len(CANDIDATES)):
        for group in by_file.values():
            if group and len(chosen) < count:
                chosen.append(group.pop())
    return chosen


def locate(tree: Path, mutant: Mutant) -> int:
    """The 1-based line number of the mutant's line; it must occur exactly once."""
    lines = (tree / mutant.path).read_text().splitlines()
    hits = [k + 1 for k, text in enumerate(lines) if text == mutant.line]
    if len(hits) != 1:
        raise SystemExit(f"{mutant.path}: line occurs {len(hits)} times: {mutant.line.strip()}")
    return hits[0]


def apply(tree: Path, mutant: Mutant) -> int:
    lineno = locate(tree, mutant)
    path = tree / mutant.path
    lines = path.read_text().splitlines(keepends=True)
    lines[lineno - 1] = mutant.replacement + "\n"
    path.write_text("".join(lines))
    return lineno


def copy_head(dest: Path) -> None:
    archive = subprocess.run(["git", "archive", "HEAD"], cwd=ROOT, capture_output=True, check=True)
    subprocess.run(["tar", "-x", "-C", str(dest)], input=archive.stdout, check=True)


def module_name(path: str) -> str:
    return "edgeaa." + path.removesuffix(".py").replace("/", ".")


def run_mutant(mutant: Mutant, timeout: float) -> dict:
    """Copy HEAD, mutate, check the import, run the covering tests; the outcome as a row."""
    with tempfile.TemporaryDirectory(prefix="edgeaa-mutant-") as tmp:
        tree = Path(tmp)
        copy_head(tree)
        lineno = apply(tree, mutant)
        env_cmd = ["env", f"PYTHONPATH={tree / 'src'}"]
        row = {"where": f"{mutant.path}:{lineno}", "caught_by": "", "seconds": 0.0}
        imported = subprocess.run(
            [*env_cmd, sys.executable, "-c", f"import {module_name(mutant.path)}"],
            cwd=tree,
            capture_output=True,
        )
        if imported.returncode != 0:
            return {**row, "outcome": "does not import (not a realistic mutant)"}
        start = time.monotonic()
        cmd = [*env_cmd, "nice", "-n", "10", sys.executable, "-m", "pytest", "-x", "-q"]
        cmd += ["-p", "no:cacheprovider", "-n", "0", *TESTS[mutant.path]]
        try:
            done = subprocess.run(cmd, cwd=tree, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return {**row, "outcome": f"timeout after {timeout:.0f} s", "seconds": timeout}
        row["seconds"] = time.monotonic() - start
        return {**row, **judge(done.returncode, done.stdout)}


def judge(returncode: int, output: str) -> dict:
    """Caught: pytest exit 1 with a FAILED test. Exit 0: survived. Anything else: an error."""
    failed = re.findall(r"^FAILED (\S+)", output, re.MULTILINE)
    if returncode == 1 and failed:
        return {"outcome": "caught", "caught_by": failed[0].split(" ")[0]}
    if returncode == 0:
        return {"outcome": "SURVIVED"}
    tail = output.strip().splitlines()[-1:] or ["(no output)"]
    return {"outcome": f"pytest exit {returncode}: {tail[0]}"}


def table(rows: list[tuple[int, Mutant, dict]]) -> str:
    lines = [
        "| id | file:line | change | outcome | caught by | s |",
        "|---|---|---|---|---|---|",
    ]
    for k, mutant, row in rows:
        lines.append(
            f"| M{k} | `{row['where']}` | {mutant.what} | {row['outcome']} | "
            f"`{row['caught_by'] or '-'}` | {row['seconds']:.0f} |"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=25)
    parser.add_argument("--count", type=int, default=10)
    parser.add_argument("--timeout", type=float, default=900.0)
    parser.add_argument("--list", action="store_true", help="check and list the picks; run none")
    args = parser.parse_args()
    chosen = pick(args.seed, args.count)
    print(f"seed {args.seed}: {len(chosen)} of {len(CANDIDATES)} candidates")
    for mutant in CANDIDATES:
        locate(ROOT, mutant)  # every candidate's line occurs exactly once
    if args.list:
        for k, mutant in enumerate(chosen, 1):
            print(f"M{k} {mutant.path}:{locate(ROOT, mutant)} {mutant.what}")
        return
    rows = []
    for k, mutant in enumerate(chosen, 1):
        row = run_mutant(mutant, args.timeout)
        rows.append((k, mutant, row))
        print(f"M{k} {row['where']}: {row['outcome']} {row['caught_by']} {row['seconds']:.0f} s")
        print(f"    - {mutant.line.strip()}\n    + {mutant.replacement.strip()}", flush=True)
    print(table(rows))
    survivors = [k for k, _, row in rows if row["outcome"] != "caught"]
    print(f"caught {len(rows) - len(survivors)} of {len(rows)}; not caught: {survivors or 'none'}")


if __name__ == "__main__":
    main()
