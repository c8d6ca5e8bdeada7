"""Numerical checks of every formula in docs/algorithm.md and docs/model.md.

Run from the repository root:

    python docs/check_derivations.py

It prints the figures the two documents quote and exits with status 1 if any check fails.
Part A checks the real-valued geometry by dense sampling (numpy) and exact rationals; part B
runs the bit-accurate model (edgeaa.model.run_edge) against the exact reference
(edgeaa.model.exact_coverage*); part C checks the register widths and the rules of
docs/model.md; part D the accumulation of docs/algorithm.md section 13 (and, D8, the bound
on a beat's accumulator clocks that docs/hardware.md's clock estimate uses). Everything is
seeded and deterministic; it takes well under a minute.
"""

from __future__ import annotations

import math
import random
import sys
import time
from fractions import Fraction
from types import SimpleNamespace

import numpy as np

from edgeaa.model import (
    Clip,
    ConfigError,
    Edge,
    EdgeConfig,
    EdgeError,
    WidthError,
    exact_coverage,
    exact_coverage_array,
    run_edge,
    setup,
)
from edgeaa.model import column as column_module
from edgeaa.model.config import UNITS_PER_EDGE
from edgeaa.model.edge import segment_constants

FAILED: list[str] = []
MODES = ("pw", "paper", "seg2", "seg4")
SEGMENTS = {"pw": 0, "paper": 1, "seg2": 2, "seg4": 4}
# c_N: the estimate's own error bound is c_N * k.
C_N = {"pw": Fraction(1, 8), "paper": Fraction(1, 64), "seg2": Fraction(1, 256)}
C_N["seg4"] = Fraction(1, 1024)


def check(name: str, ok: bool, detail: str = "") -> None:
    print(f"  [{'ok' if ok else 'FAIL':4}] {name}" + (f": {detail}" if detail else ""))
    if not ok:
        FAILED.append(name)


_CLOCK = [time.time()]


def section(title: str) -> None:
    now = time.time()
    print(f"   ({now - _CLOCK[0]:.1f} s)\n== {title}")
    _CLOCK[0] = now


# -- the fixed-point budget of docs/algorithm.md section 9 ----------------------------------


def t_bounds(n: int) -> tuple[Fraction, Fraction]:
    """(low, high): the integer triangle estimate t lies in (T_N(D) - low, T_N(D) + high).

    low  = s_max (floor of d) + (4N-1)/(4N) (the >> in the slope term)
           + (3N-2)/(4N^2) (segment chosen from floored thresholds; none for N = 1)
    high = (c_max + 64N^2 - 1)/(64N^2) (intercept from kq = floor(K), then floored)
    """
    s_max = Fraction(2 * n - 1, 4 * n)
    low = s_max + Fraction(4 * n - 1, 4 * n) + (Fraction(3 * n - 2, 4 * n * n) if n > 1 else 0)
    m = 64 * n * n
    high = Fraction(8 * (n - 1) * n + 1 + m - 1, m)
    return low, high


def units(mode: str) -> Fraction:
    """u_N: fixed-point units (2**-F intensity LSB) of the exact accumulator's error bound."""
    n = SEGMENTS[mode]
    if n == 0:
        return Fraction(1)  # pw writes floor(J)
    low, high = t_bounds(n)
    return 1 + max(low, high)  # floor(J) plus the worse side of t (the primary pixel)


# == Part A: the real-valued geometry ========================================================


def ramp(z):
    """G(z): antiderivative of clamp(z, 0, 1), G(0) = 0."""
    return np.where(z <= 0, 0.0, np.where(z >= 1, z - 0.5, 0.5 * z * z))


def column_area(f, k, r):
    """Exact A-side area of the pixel r rows beyond the primary (column centre height f)."""
    return (ramp(f + k / 2 - r) - ramp(f - k / 2 - r)) / k


def estimate(d, k, n):
    """The N-segment add-only estimate of d^2/(2k), real-valued, clamped at 0."""
    j = np.minimum(np.floor(d / (k / (2 * n))), n - 1)
    line = (2 * j + 1) / (4 * n) * d - k * (8 * j * (j + 1) + 1) / (64 * n * n)
    return np.maximum(line, 0.0)


def seg_line(n: int, j: int, d: Fraction, k: Fraction) -> Fraction:
    """The minimax line of segment j: (2j+1)/(4N) d - k (8j(j+1)+1)/(64N^2)."""
    return Fraction(2 * j + 1, 4 * n) * d - k * (8 * j * (j + 1) + 1) / (64 * n * n)


def part_a() -> None:
    ks = np.linspace(1 / 64, 1, 64)[:, None]
    f = np.linspace(0, 1, 8001, endpoint=False)[None, :]
    up = f + ks / 2 - 1 > 0  # exit above, d = f + k/2 - 1
    dn = ks / 2 - f > 0  # exit below, d = k/2 - f
    d_up, d_dn = f + ks / 2 - 1, ks / 2 - f

    section("A1 one column: at most two pixels, exits exclusive, formula (1), triangle")
    far = max(
        float(np.abs(column_area(f, ks, r) - (1.0 if r < 0 else 0.0)).max()) for r in (-3, -2, 2, 3)
    )
    check("rows beyond row-1..row+1 untouched (k <= 1)", far < 1e-12, f"max dev {far:.1e}")
    check("exits exclusive: never d_above > 0 and d_below > 0", not bool((up & dn).any()))
    a0 = column_area(f, ks, 0)
    one = ~(up | dn)
    dev1 = float(np.abs(a0 - f)[one].max())
    check("no exit: primary area = f (formula (1) exact)", dev1 < 1e-12, f"max dev {dev1:.1e}")
    tri_up, tri_dn = d_up**2 / (2 * ks), d_dn**2 / (2 * ks)
    dev_up = max(
        float(np.abs(column_area(f, ks, 1) - tri_up)[up].max()),
        float(np.abs(a0 - (f - tri_up))[up].max()),
    )
    dev_dn = max(
        float(np.abs(column_area(f, ks, -1) - (1 - tri_dn))[dn].max()),
        float(np.abs(a0 - (f + tri_dn))[dn].max()),
    )
    check("exit above: row+1 = d^2/2k, primary = f - d^2/2k", dev_up < 1e-12, f"{dev_up:.1e}")
    check("exit below: row-1 = 1 - d^2/2k, primary = f + d^2/2k", dev_dn < 1e-12, f"{dev_dn:.1e}")
    total = sum(column_area(f, ks, r) - (1.0 if r < 0 else 0.0) for r in (-1, 0, 1))
    dev_t = float(np.abs(total - f).max())
    check("column total of A area = f exactly", dev_t < 1e-12, f"max dev {dev_t:.1e}")
    kb = np.broadcast_to(ks, up.shape)
    check(
        "exit depth d in (0, k/2]",
        bool((d_up[up] < kb[up] / 2).all() and (d_dn[dn] <= kb[dn] / 2).all()),
    )

    section("A2 triangle identity and Q(t)")
    rng = random.Random(1)
    ok = True
    for _ in range(2000):
        k = Fraction(rng.randint(1, 1000), 1000)
        d = k / 2 * Fraction(rng.randint(0, 1000), 1000)
        t = k / 2 - d
        ok &= d * d / (2 * k) == d / 4 + (t * t / (2 * k) - t / 4)
    check("d^2/(2k) = d/4 + Q(k/2 - d), Q(t) = t^2/(2k) - t/4 (2000 exact rationals)", ok)
    worst_min, worst_arg, worst_end = 0.0, 0.0, 0.0
    for k in np.linspace(1 / 64, 1, 64):
        t = np.linspace(0, k / 2, 20001)
        q = t * t / (2 * k) - t / 4
        worst_min = max(worst_min, abs(q.min() / k + 1 / 32))
        worst_arg = max(worst_arg, abs(t[q.argmin()] / k - 1 / 4))
        worst_end = max(worst_end, abs(q[0]), abs(q[-1]), q.max())
    check("min Q = -k/32", worst_min < 1e-9, f"max |min/k + 1/32| = {worst_min:.1e}")
    check("argmin Q at t = k/4", worst_arg < 1e-4, f"max |argmin/k - 1/4| = {worst_arg:.1e}")
    check("max Q = 0, at t = 0 and t = k/2", worst_end < 1e-15, f"{worst_end:.1e}")

    section("A3 the paper's estimate d/4 - k/64 and its optimality (k = 1; all scales alike)")
    d = np.linspace(0, 0.5, 200001)
    tri = d * d / 2
    err = d / 4 - 1 / 64 - tri
    err_c = np.maximum(d / 4 - 1 / 64, 0) - tri
    check("max |d/4 - k/64 - d^2/2k| = k/64", abs(np.abs(err).max() - 1 / 64) < 1e-12)
    check("clamped at 0 the bound still holds", np.abs(err_c).max() <= 1 / 64 + 1e-15)
    k = Fraction(1)
    pts = [Fraction(0), k / 4, k / 2]
    errs = [p / 4 - k / 64 - p * p / (2 * k) for p in pts]
    check(
        "equioscillation at d = 0, k/4, k/2",
        errs == [-k / 64, k / 64, -k / 64],
        "errors " + ", ".join(str(e) for e in errs),
    )
    consts = np.linspace(-1 / 16, 1 / 16, 4001)
    q = (lambda t: t * t / 2 - t / 4)(np.linspace(0, 0.5, 20001))
    cerr = np.array([np.abs(c - q).max() for c in consts])
    best_c = consts[cerr.argmin()]
    check(
        "best constant c in d/4 + c is -k/64, error k/64",
        abs(best_c + 1 / 64) < 1e-4 and abs(cerr.min() - 1 / 64) < 1e-6,
        f"best c = {best_c:.6f}, error {cerr.min():.6f}",
    )
    slopes = np.linspace(0.15, 0.35, 2001)
    lerr = np.array([(np.ptp(tri - a * d)) / 2 for a in slopes])
    best_a = slopes[lerr.argmin()]
    check(
        "best line a*d + b: a = 1/4, error k/64 (nothing better)",
        abs(best_a - 0.25) < 1e-4 and lerr.min() >= 1 / 64 - 1e-12,
        f"best a = {best_a:.5f}, error {lerr.min():.6f} = 1/{1 / lerr.min():.2f}",
    )

    section("A4 N-segment estimate: slopes, intercepts, continuity, error k/(64 N^2)")
    print(f"  {'N':>2} {'max err/k (dense)':>18} {'1/(64N^2)':>10} {'sliver d<':>10}")
    for n in (1, 2, 4):
        k = Fraction(1)
        ok = True
        for j in range(n):
            a, b = j * k / (2 * n), (j + 1) * k / (2 * n)
            chord_slope = (b * b - a * a) / (2 * k) / (b - a)
            chord_icpt = a * a / (2 * k) - chord_slope * a
            ok &= chord_slope == Fraction(2 * j + 1, 4 * n)
            ok &= chord_icpt - k / (64 * n * n) == -k * (8 * j * (j + 1) + 1) / (64 * n * n)
            mid = (a + b) / 2
            ok &= (chord_slope * mid + chord_icpt) - mid * mid / (2 * k) == k / (32 * n * n)
            if j + 1 < n:  # lines j and j+1 meet on the boundary b
                ok &= seg_line(n, j, b, k) == seg_line(n, j + 1, b, k)
        check(f"N={n}: chord slopes (2j+1)/(4N), intercepts, continuity (exact)", ok)
        dd = np.linspace(0, 0.5, 400001)
        e = np.abs(estimate(dd, 1.0, n) - dd * dd / 2).max()
        lines = np.array(
            [(2 * i + 1) / (4 * n) * dd - (8 * i * (i + 1) + 1) / (64 * n * n) for i in range(n)]
        )
        piece = estimate(dd, 1.0, n)
        conv = np.abs(np.maximum(lines.max(axis=0), 0) - piece).max()
        check(f"N={n}: piecewise estimate = max of its lines (convex)", conv < 1e-15)
        check(f"N={n}: max error = k/{64 * n * n}", abs(e - 1 / (64 * n * n)) < 1e-9, f"{e:.7f}")
        print(f"  {n:>2} {e:18.7f} {1 / (64 * n * n):10.7f} {'k/' + str(16 * n):>10}")

    section("A5 pw (formula (1) alone, one pixel per column): worst case k/8")
    e_pw = np.where(up, tri_up, np.where(dn, tri_dn, 0.0))  # primary error = unlit triangle
    ratio = (e_pw.max(axis=1) / ks[:, 0]).max()
    at = np.unravel_index(e_pw.argmax(), e_pw.shape)
    check(
        "max error of formula (1) = k/8 (attained at f = 0, exit below)",
        abs(ratio - 1 / 8) < 1e-12 and f[0, at[1]] == 0.0,
        f"max err/k = {ratio:.6f}",
    )
    paper_0062()


def paper_0062() -> None:
    """Candidate statistics for the paper's '0.062' for formula (1)."""
    section("A6 the paper's 0.062 for formula (1): candidate statistics")
    f = np.linspace(0, 1, 200001)

    def pw_err(k):
        up, dn = f + k / 2 - 1, k / 2 - f
        return np.where(up > 0, up * up / (2 * k), np.where(dn > 0, dn * dn / (2 * k), 0.0))

    kk = (np.arange(2000) + 0.5) / 2000  # midpoint rule
    theta = (np.arange(2000) + 0.5) / 2000 * math.pi / 4
    rows = [
        ("max error at k = 1/2 (26.6 deg)", pw_err(0.5).max()),
        ("mean over k in [0,1] of the max error k/8", float(np.mean(kk / 8))),
        ("mean over angle in [0,45deg] of the max error", float(np.mean(np.tan(theta) / 8))),
        ("max error at 45 deg (k = 1)", pw_err(1.0).max()),
        ("mean error over offsets at 45 deg", pw_err(1.0).mean()),
        ("RMS error over offsets at 45 deg", math.sqrt((pw_err(1.0) ** 2).mean())),
        ("mean error over offsets and k", float(np.mean([pw_err(k).mean() for k in kk[::20]]))),
        ("RMS over offsets and k", math.sqrt(np.mean([(pw_err(k) ** 2).mean() for k in kk[::20]]))),
        ("max error, endpoints on pixel centres, du<=64", pixel_centre_max()),
    ]
    print(f"  {'statistic of the formula (1) error':48} {'value':>8}  = 0.062?")
    hits = []
    for name, value in rows:
        hit = abs(value - 0.0625) < 5e-4
        hits.append(hit)
        print(f"  {name:48} {value:8.5f}  {'yes (1/16)' if hit else 'no'}")
    check("exactly two candidates equal 1/16 = 0.0625", hits[:2] == [True, True] and sum(hits) == 2)


def pixel_centre_max() -> float:
    """Worst formula (1) error over lines through pixel centres with du <= 64."""
    worst = 0.0
    for du in range(1, 65):
        for dv in range(0, du + 1):
            k = dv / du
            if k == 0:
                continue
            for x in range(du):
                f = (x * dv + du / 2) % du / du  # line from a pixel centre: f0 = 1/2
                d = max(f + k / 2 - 1, k / 2 - f)
                if d > 0:
                    worst = max(worst, d * d / (2 * k))
    return worst


# == Part B: the bit-accurate model against the exact area ===================================


def writes_errors(config: EdgeConfig, edge: Edge):
    """Per write: (column index, k, ifix, |model - exact|, |output - exact|)."""
    result = run_edge(config, edge)
    st = result.setup
    xs = [w.x for w in result.writes]
    ys = [w.y for w in result.writes]
    exact = exact_coverage_array(config, edge, xs, ys)
    i_in, i_out = edge.intensities(config)
    out = []
    for w, e in zip(result.writes, exact, strict=True):
        col = (w.x - st.x) * st.col_dx + (w.y - st.y) * st.col_dy
        model = result.coverage(w)
        output = (w.value - i_out) / (i_in - i_out)
        out.append((col, st.dv / st.du, st.ifix, abs(model - e), abs(output - e), w))
    return result, out


def sweep_edges(config: EdgeConfig, slopes: int, length_px: int, offsets) -> list[Edge]:
    """Edges of slope ~ i/slopes, one per sub-pixel start offset (in 1/256 px)."""
    scale = config.subpixel_scale
    du = length_px * scale + 37  # odd-ish length: the column offsets f fill [0, 1) densely
    edges = []
    for i in range(0, slopes + 1):
        dv = round(du * i / slopes)
        for a, b in offsets:
            x0, y0 = 2 * scale + a * scale // 256, 2 * scale + b * scale // 256
            edges.append(Edge(x0, y0, x0 + du, y0 + dv, i_in=255, i_out=0))
    return edges


def part_b() -> None:
    section("B1 model vs exact area: coord_bits 11, subpixel_bits 8, I 8, |I_d| = 255, exact")
    # F = 21 (set): a unit negligible, so the measured maximum shows the estimate's c_N k
    base = EdgeConfig(coord_bits=11, subpixel_bits=8, intensity_bits=8, frac_bits=21)
    edges = sweep_edges(base, slopes=64, length_px=300, offsets=[(0, 0), (0, 128), (93, 201)])
    print(f"  F = {base.F}; {len(edges)} edges, slopes k = i/64, 300 columns each, 3 offsets")
    print(
        f"  {'mode':6} {'writes':>7} {'max |err|':>10} {'max err/k':>10} {'bound/k':>10}"
        f" {'fp units':>8} {'u_N':>6} {'rnd':>6}"
    )
    for mode in MODES:
        config = base.with_(mode=mode)
        cn, un = float(C_N[mode]), float(units(mode))
        n_writes, worst, worst_k, worst_units, worst_out, bad = 0, 0.0, 0.0, -1e9, 0.0, 0
        worst_write = None
        for edge in edges:
            _, rows = writes_errors(config, edge)
            for _col, k, ifix, err, out_err, w in rows:
                n_writes += 1
                if err > worst:
                    worst, worst_write = err, (edge, w)
                if k > 0:
                    worst_k = max(worst_k, err / k)
                worst_units = max(worst_units, (err - cn * k) * ifix)
                worst_out = max(worst_out, (out_err - cn * k - un / ifix) * 510)
                bad += err > cn * k + un / ifix + 1e-12
        print(
            f"  {mode:6} {n_writes:7d} {worst:10.6f} {worst_k:10.6f} {cn:10.6f}"
            f" {worst_units:8.3f} {un:6.3f} {worst_out:6.3f}"
        )
        check(f"{mode}: every write within c_N k + u_N/ifix", bad == 0, f"{bad} over")
        check(f"{mode}: bound attained (max err/k >= 0.99 c_N)", worst_k >= 0.99 * cn)
        check(f"{mode}: output within + 1/(2|I_d|) more", worst_out <= 1 + 1e-9)
        edge, w = worst_write
        exact = exact_coverage(config, edge, w.x, w.y)
        model = run_edge(config, edge).coverage(w)
        check(
            f"{mode}: worst write re-checked with exact rationals",
            abs(abs(model - float(exact)) - worst) < 1e-12,
            f"pixel ({w.x}, {w.y}) err {worst:.6f}",
        )

    section("B2 all octants, both inside sides, swapped intensities")
    config_all = [base.with_(mode=m) for m in MODES]
    centre = 1000 * 256 + 77
    bad = 0
    count = 0
    for i in range(1, 9):
        du, dv = 40 * 256 + 19, (40 * 256 + 19) * i // 8
        for sx in (1, -1):
            for sy in (1, -1):
                for swap in (False, True):
                    dx, dy = (sx * dv, sy * du) if swap else (sx * du, sy * dv)
                    for inside in ("left", "right"):
                        edge = Edge(
                            centre, centre + 50, centre + dx, centre + 50 + dy, inside, 17, 240
                        )
                        for config in config_all:
                            cn, un = float(C_N[config.mode]), float(units(config.mode))
                            for _c, k, ifix, err, _o, _w in writes_errors(config, edge)[1]:
                                count += 1
                                bad += err > cn * k + un / ifix + 1e-12
    check("8 octants x 2 sides x 8 slopes x 4 modes within bound", bad == 0, f"{count} writes")

    section("B3 fixed-point units with a small F: (|err| - c_N k) * ifix")
    print("  t in (T_N - low, T_N + high):  N  low  high  ->  u_N = 1 + max(low, high)")
    for mode in MODES[1:]:
        low, high = t_bounds(SEGMENTS[mode])
        print(f"  {mode:6} {float(low):8.5f} {float(high):8.5f} -> u_N = {float(units(mode)):.5f}")
    triangle_exhaustive()
    rng = random.Random(7)
    print(f"  {'mode':6} {'acc':9} {'writes':>7} {'max units':>9} {'max u - n':>9} {'u_N':>7}")
    for acc in ("exact", "truncated"):
        for mode in MODES:
            un = float(units(mode))
            n_writes, worst, worst_n = 0, -1e9, -1e9
            for it in range(220):
                s = (0, 3, 8)[it % 3]
                cfg = EdgeConfig(coord_bits=5, subpixel_bits=s, mode=mode, accumulator=acc)
                cfg = cfg.with_(frac_bits=cfg.min_frac_bits + (0, 0, 2)[it % 3])
                hi = cfg.max_vertex
                du = rng.choice((rng.randint(1, hi), rng.randint(1, 3 * cfg.subpixel_scale)))
                dv = rng.choice((rng.randint(0, du), rng.randint(0, 3), du))
                dx, dy = (du, dv) if rng.random() < 0.5 else (dv, du)
                dx, dy = dx * rng.choice((1, -1)), dy * rng.choice((1, -1))
                x0 = rng.randint(max(0, -dx), min(hi, hi - dx))
                y0 = rng.randint(max(0, -dy), min(hi, hi - dy))
                i_d = rng.choice((1, 1, 2, 5, 255))
                edge = Edge(x0, y0, x0 + dx, y0 + dy, rng.choice(("left", "right")), i_d, 0)
                cn = float(C_N[mode])
                for col, k, ifix, err, _o, _w in writes_errors(cfg, edge)[1]:
                    n_writes += 1
                    u = (err - cn * k) * ifix
                    worst = max(worst, u)
                    worst_n = max(worst_n, u - col)
            shown = f"{worst:9.4f} {'-':>9}" if acc == "exact" else f"{'-':>9} {worst_n:9.4f}"
            print(f"  {mode:6} {acc:9} {n_writes:7d} {shown} {un:7.4f}")
            if acc == "exact":
                check(f"{mode} exact: < u_N units", worst < un)
            else:
                check(f"{mode} truncated: < u_N + n units in column n", worst_n < un)
    drift_budget()


def triangle_exhaustive() -> None:
    """t - T(D) over all small K and depths D, through the model's own triangle_estimate.

    K < 3N - 1 units (where more than one threshold can be crossed early): 32 fractions of K,
    D every 1/64 unit. Every other kq < 160: 4 fractions, D every 1/8 unit. Plus 40 large
    random kq. D just below each integer (the worst case of the floor) is always included.
    """
    rng = random.Random(3)
    for n, mode in ((1, "paper"), (2, "seg2"), (4, "seg4")):
        config = EdgeConfig(mode=mode)
        low, high = t_bounds(n)
        unchecked = column_module.IntArith(config)  # where=False: no width check here
        lo_seen, hi_seen = 0.0, 0.0
        for kq in list(range(0, 160)) + [rng.randint(160, 10**6) for _ in range(40)]:
            thresholds, intercepts = segment_constants(config, kq)
            st = SimpleNamespace(seg_thresholds=thresholds, seg_intercepts=intercepts)
            tiny = kq < 3 * n - 1
            for frac in [i / 32 for i in range(32)] if tiny else (0.0, 0.3, 0.7, 0.999):
                kk = kq + frac
                if kk == 0:
                    continue
                per_unit = 64 if tiny else 8
                steps = 400 if kq > 159 else max(8, int(kk / 2 * per_unit))
                depths = [kk / 2 * i / steps for i in range(1, steps + 1)]
                ends = range(1, int(kk / 2) + 1)
                if kq > 159:  # large K: 400 of its integers
                    ends = [rng.randint(1, int(kk / 2)) for _ in range(400)]
                depths += [m - 1e-6 for m in ends]
                for dd in depths:
                    raw = column_module.triangle_estimate(
                        unchecked, config, st, math.floor(dd), where=False
                    )
                    t = max(raw, 0)
                    exact_t = dd * dd / (2 * kk)
                    margin = kk / (64 * n * n)
                    lo_seen = min(lo_seen, t - exact_t + margin)
                    hi_seen = max(hi_seen, t - exact_t - margin)
        check(
            f"N={n}: t - d^2/2k within (-low - K/64N^2, high + K/64N^2) units",
            lo_seen > -low and hi_seen < high,
            f"seen ({lo_seen:.4f}, {hi_seen:.4f}) vs ({-float(low):.4f}, {float(high):.4f})",
        )


def drift_budget() -> None:
    section("B4 truncated drift on the longest edge, |I_d| = 1 (coord_bits 11, s 4, I 8)")
    base = EdgeConfig(mode="paper", accumulator="truncated")
    hi, i_bits = base.max_vertex, base.intensity_bits
    budget = 2.0 ** -(i_bits + 1)
    print(f"  max_columns = {base.max_columns}, derived F = {base.F}, 2^-(I+1) = {budget}")
    print(
        f"  {'F':>3} {'frac(K)':>8} {'drift':>7} {'drift*2^-F':>10} {'cols*2^-F':>10}"
        f" {'max|err| exact':>14} {'max|err| trunc':>14} {'k/64':>9}"
    )
    for df in (0, -3, -6):
        F = base.F + df
        dv = (-pow(2, -F, hi)) % hi  # K = k 2^F has fraction 1 - 1/du: the worst truncation
        edge = Edge(0, 0, hi, dv, "left", 1, 0)  # the longest edge: 2^W + 1 columns
        runs = {}
        for acc in ("exact", "truncated"):
            cfg = base.with_(frac_bits=F, accumulator=acc)
            runs[acc] = writes_errors(cfg, edge)
        ex, tr = runs["exact"][0], runs["truncated"][0]
        st = ex.setup
        # Height of the line at each column centre in units: row * ifix + J (J = jq + jr/du).
        drift = [
            (a.y * st.ifix + a.jq + Fraction(a.jr, st.du)) - (b.y * st.ifix + b.jq)
            for a, b in zip(ex.trace, tr.trace, strict=True)
        ]
        ok_drift = all(0 <= dr < n + 1 for n, dr in enumerate(drift))
        last = float(drift[-1])
        k = st.dv / st.du
        err = {acc: max(r[3] for r in runs[acc][1]) for acc in runs}
        frac_k = float(Fraction(st.dv << F, st.du) % 1)
        print(
            f"  {F:3d} {frac_k:8.5f} {last:7.1f} {last * 2**-F:10.3e} {st.columns * 2**-F:10.3e}"
            f" {err['exact']:14.3e} {err['truncated']:14.3e} {k / 64:9.3e}"
        )
        check(f"F={F}: drift in column n is in [0, n + 1) units", ok_drift)
        bound = k / 64 + (float(units("paper")) + st.columns - 1) / 2**F
        check(f"F={F}: truncated within c_N k + (u_N + n)/2^F", err["truncated"] <= bound)
        if df == 0:
            check(f"F={F}: drift*2^-F <= 2^-(I+1) (the budget)", last * 2**-F <= budget)
        if df == -6:
            check(f"F={F}: drift*2^-F > 2^-(I+1) (F too small)", last * 2**-F > budget)


# == Part C: docs/model.md ===================================================================


class Recorder:
    """Wraps the step model's width check (`column.IntArith.check`) to record each
    register's extremes (of the registers it assigns: where the check applies)."""

    seen: dict[str, list[int]] = {}

    @classmethod
    def install(cls):
        original = column_module.IntArith.check

        def call(self, name, value, where=True):
            if where:
                lo_hi = cls.seen.setdefault(name, [value, value])
                lo_hi[0], lo_hi[1] = min(lo_hi[0], value), max(lo_hi[1], value)
            return original(self, name, value, where)

        column_module.IntArith.check = call
        return original


def extreme_edges(config: EdgeConfig) -> list[Edge]:
    hi, full, s = config.max_vertex, config.full_scale, config.subpixel_scale
    mid = hi // 2
    return [
        Edge(0, 0, hi, hi, "left", full, 0),  # k = 1, whole range
        Edge(hi, hi, 0, 0, "right", 0, full),
        Edge(0, hi, hi, 0, "left", full, 0),
        Edge(0, 0, hi, 0, "left", full, 0),  # k = 0 on the top row
        Edge(hi, hi, 0, hi, "right", full, 0),  # k = 0 on the bottom row
        Edge(0, 0, hi, hi - 1, "left", 0, full),  # k just below 1
        Edge(hi, 0, 0, 1, "left", full, 0),  # k just above 0
        Edge(0, 0, 1, 1, "left", full, 0),  # shortest
        Edge(mid, 0, mid + s // 2, hi, "right", full, 0),  # steep, y-major
        Edge(hi, mid, 0, mid + 1, "left", 1, 0),  # |I_d| = 1
    ]


def part_c() -> None:
    section("C1 derived frac bits: truncated W + I + 2, exact I + 3 (EdgeConfig.F)")
    intens = (4, 8, 10, 12)
    print("  truncated, W \\ I " + "".join(f"{i:>5}" for i in intens))
    ok = True
    for w in range(8, 17):
        row = []
        for i in intens:
            cfg = EdgeConfig(coord_bits=w, intensity_bits=i, accumulator="truncated")
            frac_bits = cfg.F
            row.append(frac_bits)
            ok &= cfg.max_columns * Fraction(1, 2**frac_bits) <= Fraction(1, 2 ** (i + 1))
            ok &= cfg.max_columns * Fraction(1, 2 ** (frac_bits - 1)) > Fraction(1, 2 ** (i + 1))
            ok &= frac_bits == w + 1 + i + 1
        print(f"  {w:17d} " + "".join(f"{v:5d}" for v in row))
    check("truncated: max_columns*2^-F <= 2^-(I+1) holds and F-1 breaks it; F = W + I + 2", ok)
    ok, row = True, []
    for i in range(1, 17):
        cfg = EdgeConfig(intensity_bits=i)
        row.append(cfg.F)
        ok &= UNITS_PER_EDGE * Fraction(1, 2**cfg.F) <= Fraction(1, 2 ** (i + 1))
        if cfg.min_frac_bits < cfg.F:  # above the floor, one bit fewer breaks the budget
            ok &= UNITS_PER_EDGE * Fraction(1, 2 ** (cfg.F - 1)) > Fraction(1, 2 ** (i + 1))
            ok &= i + 3 == cfg.F
    print("  exact, I = 1..16:   " + " ".join(str(v) for v in row))
    check(
        "exact: 4 units * 2^-F <= 2^-(I+1) holds and F-1 breaks it; F = max(I + 3, floor)",
        ok,
        f"every W; floor {EdgeConfig().min_frac_bits} for paper, s = 4",
    )

    section("C2 register widths at the extremes (run_edge raises WidthError on overflow)")
    original = column_module.IntArith.check
    overflows = []

    def try_run(cfg: EdgeConfig, edge: Edge) -> None:
        try:
            run_edge(cfg, edge)
        except WidthError as error:
            overflows.append(f"{cfg} {edge}: {error}")
            print(f"  WidthError {overflows[-1]}")

    try:
        # The default configuration's width table, recording each register's extremes (both
        # accumulators at the default F; the truncated one's own derived F runs below).
        Recorder.install()
        default = EdgeConfig()
        rng = random.Random(5)
        runs = 0
        for mode in MODES:
            for acc in ("exact", "truncated"):
                cfg = default.with_(mode=mode, accumulator=acc, frac_bits=default.F)
                edges = extreme_edges(cfg)
                for _ in range(5):
                    hi = cfg.max_vertex
                    pts = [rng.randint(0, hi) for _ in range(4)]
                    if pts[:2] != pts[2:]:
                        edges.append(Edge(*pts, "left", rng.randint(1, 255), 0))
                for edge in edges:
                    try_run(cfg, edge)
                    runs += 1
        column_module.IntArith.check = original
        for base in (
            EdgeConfig(),
            EdgeConfig(coord_bits=2, subpixel_bits=0, intensity_bits=1),
            EdgeConfig(coord_bits=2, subpixel_bits=8, intensity_bits=16),
            EdgeConfig(coord_bits=6, subpixel_bits=3, intensity_bits=4),
        ):
            for mode in MODES:
                for acc in ("exact", "truncated"):
                    cfg = base.with_(mode=mode, accumulator=acc)
                    for edge in extreme_edges(cfg):
                        try_run(cfg, edge)
                        runs += 1
        # The widest configuration: 65537 columns per edge, so only the k = 1 and near-1 edges.
        big = EdgeConfig(coord_bits=16, subpixel_bits=8, intensity_bits=16)
        try_run(big.with_(mode="seg4"), extreme_edges(big)[0])
        try_run(big.with_(accumulator="truncated"), extreme_edges(big)[5])
        runs += 2
        check("extreme edges (W=2..16, s=0..8, I=1..16, all modes) fit", not overflows, f"{runs}")
        widths = default.register_widths()
        ifix_max = default.full_scale << default.F
        print(f"  default config: W=11 s=4 I=8 F={default.F}; max ifix = {ifix_max}")
        print(f"  {'register':10} {'bits':>4} {'sgn':>3} {'declared range':>27} {'observed':>27}")
        for name, width in widths.items():
            lo, hi = Recorder.seen.get(name, [None, None])
            print(
                f"  {name:10} {width.bits:4d} {'s' if width.signed else 'u':>3}"
                f" {f'[{width.min}, {width.max}]':>27} {f'[{lo}, {hi}]':>27}"
            )
        seen = Recorder.seen
        check(
            "dq in [-ifix, ifix/2] (fits acc+1 signed)",
            -ifix_max <= seen["dq"][0] and seen["dq"][1] <= ifix_max // 2,
        )
        check(
            "t in (-ifix/8, ifix/4)", -ifix_max / 8 < seen["t"][0] and seen["t"][1] < ifix_max / 4
        )
        check("area <= ifix (fits acc bits)", seen["area"][1] <= ifix_max)
        check("jsum < 2 ifix", seen["jsum"][1] < 2 * ifix_max)
    finally:
        column_module.IntArith.check = original

    section("C3 written coordinates: columns 0..2^W, rows -1..2^W+1 (exhaustive W=2, s=1)")
    cfg = EdgeConfig(coord_bits=2, subpixel_bits=1, intensity_bits=4, mode="paper")
    hi = cfg.max_vertex
    xs, ys = set(), set()
    for x0 in range(hi + 1):
        for y0 in range(hi + 1):
            for x1 in range(hi + 1):
                for y1 in range(hi + 1):
                    if (x0, y0) != (x1, y1):
                        for w in run_edge(cfg, Edge(x0, y0, x1, y1)).writes:
                            xs.add(w.x)
                            ys.add(w.y)
    print(f"  W=2 s=1: written x in [{min(xs)}, {max(xs)}], y in [{min(ys)}, {max(ys)}]")
    check("W=2 s=1 writes stay in [-1, 2^W + 1]", min(xs | ys) >= -1 and max(xs | ys) <= 5)
    cfg3 = EdgeConfig(coord_bits=2, subpixel_bits=3, intensity_bits=4)
    top = run_edge(cfg3, Edge.from_pixels(cfg3, "0.125", "1.875", "2.625", "3.875")).writes
    low = run_edge(cfg3, Edge.from_pixels(cfg3, "0.125", "2.125", "2.625", "0.125")).writes
    ys3 = [w.y for w in top + low]
    check("row 2^W + 1 and row -1 are reached (W=2 s=3)", max(ys3) == 5 and min(ys3) == -1)

    section("C4 endpoint rule, primary row, neighbour written iff the line enters it")
    rng = random.Random(11)
    bad_cols = bad_primary = bad_nb = bad_j = checked = 0
    for it in range(500):
        cfg = EdgeConfig(coord_bits=4, subpixel_bits=(0, 2, 4)[it % 3], mode="paper")
        hi, scale = cfg.max_vertex, cfg.subpixel_scale
        pts = [rng.randint(0, hi) for _ in range(4)]
        if pts[:2] == pts[2:]:
            continue
        edge = Edge(*pts, rng.choice(("left", "right")), 9, 2)
        result = run_edge(cfg, edge)
        st = result.setup
        p0, p1, q0 = (edge.x0, edge.x1, edge.y0) if st.x_major else (edge.y0, edge.y1, edge.x0)
        sm = 1 if p1 > p0 else -1
        sn = st.row_dx + st.row_dy
        u0, u1 = Fraction(sm * p0, scale), Fraction(sm * p1, scale)
        v0 = Fraction(sn * q0, scale)
        k = st.k
        cols = [c for c in range(-40, 41) if c + Fraction(1, 2) > u0 and c - Fraction(1, 2) < u1]
        bad_cols += st.columns != len(cols)
        by_col: dict[int, list] = {}
        for w in result.writes:
            by_col.setdefault((w.x - st.x) * st.col_dx + (w.y - st.y) * st.col_dy, []).append(w)
        for n, c in enumerate(cols):
            ws = by_col.get(n, [])
            vc = v0 + k * (c - u0)
            prim = ws[0]
            row = sn * (prim.y if st.x_major else prim.x)
            bad_primary += not (row - Fraction(1, 2) <= vc < row + Fraction(1, 2))
            state = result.trace[n]
            j_exact = st.ifix * (vc - row + Fraction(1, 2))  # J = |I_d| f 2^F
            bad_j += state.jq + Fraction(state.jr, st.du) != j_exact
            for r in (-2, -1, 1, 2):
                px = prim.x + r * st.row_dx
                py = prim.y + r * st.row_dy
                cov = exact_coverage(cfg, edge, px, py)
                enters = 0 < cov < 1
                written = any((w.x, w.y) == (px, py) for w in ws[1:])
                bad_nb += enters != written
                checked += 1
    check("columns = those whose interior the projection overlaps", bad_cols == 0)
    check("primary span [y-1/2, y+1/2) holds the centre crossing", bad_primary == 0)
    check("exact accumulator: jq + jr/du = |I_d| f 2^F in every column", bad_j == 0)
    check(
        "neighbour written iff the line enters it (exact)", bad_nb == 0, f"{checked} pixels tested"
    )

    section("C5 inside convention, order of writes, trace")
    cfg = EdgeConfig(subpixel_bits=2)
    r = run_edge(cfg, Edge.from_pixels(cfg, 0, "5.25", 10, "5.25", inside="left"))
    w = next(w for w in r.writes if (w.x, w.y) == (3, 5))
    check("rightward edge, inside left = up (y smaller): pixel (3,5) 3/4 inside", w.value == 191)
    r = run_edge(cfg, Edge.from_pixels(cfg, 10, "5.25", 0, "5.25", inside="left"))
    w = next(w for w in r.writes if (w.x, w.y) == (3, 5))
    check("leftward edge, inside left = down: pixel (3,5) 1/4 inside", w.value == 64)
    print(f"  {'(dx, dy)':9} {'x_major':>7} {'s_major':>7} {'s_minor':>7} {'det':>4} {'left=A':>6}")
    ok = True
    for dx, dy in ((8, 3), (3, 8), (-3, 8), (-8, 3), (-8, -3), (-3, -8), (3, -8), (8, -3)):
        st = setup(cfg, Edge(40, 40, 40 + dx, 40 + dy, "left"))
        s_major, s_minor = st.col_dx + st.col_dy, st.row_dx + st.row_dy
        det = (1 if st.x_major else -1) * s_major * s_minor
        ok &= st.inside_is_a == (det == 1)
        print(
            f"  {f'({dx}, {dy})':9} {st.x_major!s:>7} {s_major:7d} {s_minor:7d} {det:4d}"
            f" {st.inside_is_a!s:>6}"
        )
    check("inside = left is the A side iff det = +1", ok)
    r = run_edge(cfg.with_(mode="seg2"), Edge.from_pixels(cfg, 1, 1, "9.5", "4.75"))
    first = {}
    for w in r.writes:
        first.setdefault((w.x - r.setup.x) * r.setup.col_dx + (w.y - r.setup.y) * r.setup.col_dy, w)
    ok = len(r.trace) == r.setup.columns and all(
        (first[s.column].x, first[s.column].y) == (s.x, s.y) for s in r.trace
    )
    check("trace: one state per column; its (x, y) is the column's first (primary) write", ok)

    section("C6 input validation")
    bad_inputs = [
        (lambda: EdgeConfig(coord_bits=17), ConfigError),
        (lambda: EdgeConfig(subpixel_bits=9), ConfigError),
        (lambda: EdgeConfig(intensity_bits=0), ConfigError),
        (lambda: EdgeConfig(frac_bits=5), ConfigError),
        (lambda: EdgeConfig(mode="seg8"), ConfigError),
        (lambda: EdgeConfig(accumulator="float"), ConfigError),
        (lambda: setup(EdgeConfig(), Edge(0, 0, 32768, 0)), EdgeError),
        (lambda: setup(EdgeConfig(), Edge(5, 5, 5, 5)), EdgeError),
        (lambda: setup(EdgeConfig(), Edge(0, 0, 9, 9, "up")), EdgeError),
        (lambda: setup(EdgeConfig(), Edge(0, 0, 9, 9, i_in=256)), EdgeError),
        (lambda: setup(EdgeConfig(), Edge(0, 0, 9, 9, i_in=7, i_out=7)), EdgeError),
        (lambda: Edge.from_pixels(EdgeConfig(), "1.03", 0, 2, 2), EdgeError),
        (lambda: setup(EdgeConfig(), Edge(0, 0, 9, 9, clip=(0, 0, 3000, 9))), EdgeError),
    ]
    ok = True
    for make, kind in bad_inputs:
        try:
            make()
            ok = False
            print("  no error raised")
        except kind as error:
            print(f"  {kind.__name__}: {error}")
    check("every bad input raises its error with a message", ok)

    section("C7 clip window: the clipped edge is the visible part of the edge")
    rng = random.Random(7)
    top = 1 << 11
    counts = {"exact": [0, 0], "truncated": [0, 0]}
    worst = 0
    for accumulator in counts:
        cfg = EdgeConfig(mode="seg2", accumulator=accumulator)
        for _ in range(400):
            m = cfg.max_vertex
            x0, y0, x1, y1 = (rng.randint(0, m) for _ in range(4))
            if (x0, y0) == (x1, y1):
                continue
            edge = Edge(x0, y0, x1, y1)
            a, b = sorted(rng.randint(0, top) for _ in range(2))
            c, d = sorted(rng.randint(0, top) for _ in range(2))
            whole = run_edge(cfg, edge)
            cut = run_edge(cfg, Edge(x0, y0, x1, y1, clip=Clip(a, c, b, d)))
            lo, hi = (a, b) if whole.setup.x_major else (c, d)
            major = (lambda w: w.x) if whole.setup.x_major else (lambda w: w.y)
            shown = [col for col in whole.columns if lo <= major(col[0]) <= hi]
            counts[accumulator][0] += 1
            counts[accumulator][1] += shown == cut.columns
            if accumulator == "truncated":
                values = {(w.x, w.y): w.value for col in shown for w in col}
                worst = max([worst] + [abs(values[(w.x, w.y)] - w.value) for w in cut.writes])
    for accumulator, (n, same) in counts.items():
        print(f"  {accumulator:9}: {same} of {n} random clipped edges equal the visible columns")
    check(
        "exact accumulator: every clipped edge is exactly its visible columns",
        counts["exact"][0] == counts["exact"][1],
    )
    check("truncated: the restart changes values by at most 1 LSB", worst <= 1, f"max {worst}")


# -- part D: accumulation (docs/algorithm.md section 13) ---------------------------------------


def piece_area_right(k: float, hs: float, he: float, lo: float, hi: float, n: int = 4000):
    """Area on the +u side of a straight piece over one column (u in [0, 1]) from height hs
    to he, inside the height band [lo, hi], by dense sampling of the band."""
    v = lo + (np.arange(n) + 0.5) * (hi - lo) / n
    v = v[(v > hs) & (v < he)]
    u = (v - hs) / k  # the piece's u at height v (u from 0)
    return float(np.sum(1.0 - u) * (hi - lo) / n)


def part_d_split_tables() -> None:
    section("D1. x-major and y-major splits of a whole column (13.2, 13.3)")
    rng = np.random.default_rng(13)
    worst = 0.0
    for _ in range(300):
        k = float(rng.uniform(0.05, 1.0))
        j = float(rng.uniform(0, 1))  # centre height in row r (units of a pixel)
        hs, he = j - k / 2, j + k / 2
        if he > 1:  # exit above
            d = he - 1
            t = d * d / (2 * k)
            want = {"r": k / 2 - t, "r+1": t}
            got = {
                "r": piece_area_right(k, hs, he, 0, 1),
                "r+1": piece_area_right(k, hs, he, 1, 2),
            }
        elif hs < 0:  # exit below
            d = -hs
            t = d * d / (2 * k)
            want = {"r-1": d - t, "r": k / 2 - d + t}
            got = {
                "r-1": piece_area_right(k, hs, he, -1, 0),
                "r": piece_area_right(k, hs, he, 0, 1),
            }
        else:
            want = {"r": k / 2}
            got = {"r": piece_area_right(k, hs, he, 0, 1)}
        worst = max(worst, max(abs(got[key] - want[key]) for key in want))
    check("x-major table: row areas on the +u side (300 columns)", worst < 2e-3, f"{worst:.1e}")
    # y-major: A areas per cell are section 3.3's table, differenced: the deltas sum to band.
    ok = all(
        sum((1 - a_up, a_up - a_mid, a_mid - a_low, a_low)) == 1
        for a_up, a_mid, a_low in ((1, Fraction(3, 8), 0), (Fraction(7, 8), Fraction(1, 2), 0))
    )
    check("y-major deltas (band - A(r-1), A(r-1) - A(r), A(r) - A(r+1), A(r+1)) sum to band", ok)


def _random_polygon(rng: random.Random, config: EdgeConfig, n: int) -> list[tuple[int, int]]:
    hi = min(config.max_vertex, 40 * config.subpixel_scale)
    return [(rng.randint(0, hi), rng.randint(0, hi)) for _ in range(n)]


def part_d_no_leak() -> None:
    section("D2. covers telescope: every row of a closed polygon sums to zero (13.4)")
    from edgeaa.model.vector import run_edges_deltas

    rng = random.Random(21)
    configs = [
        EdgeConfig(coord_bits=6, mode=m, subpixel_bits=s, accumulator=a)
        for m in MODES
        for s in (0, 2, 4)
        for a in ("exact", "truncated")
    ]
    leaks = polygons = 0
    for config in configs:
        for _ in range(12):
            pts = _random_polygon(rng, config, rng.randint(3, 9))
            edges = [
                Edge(*p, *q, "left", config.full_scale, 0)
                for p, q in zip(pts, pts[1:] + pts[:1], strict=True)
                if p != q
            ]
            if not edges:
                continue
            batch = run_edges_deltas(config, edges)
            rows: dict[int, int] = {}
            for y, delta in zip(batch.y.tolist(), batch.delta.tolist(), strict=True):
                rows[y] = rows.get(y, 0) + delta
            leaks += any(rows.values())
            polygons += 1
    check(f"no row leaks: {polygons} random polygons, {len(configs)} configurations", leaks == 0)


def part_d_end_totals() -> None:
    section("D3. end pieces: totals of partial columns within 3/2 units (13.5)")
    rng = random.Random(5)
    config = EdgeConfig(coord_bits=6, mode="paper")
    S, worst = config.subpixel_scale, Fraction(0)
    for _ in range(500):
        x0, x1 = sorted(rng.sample(range(S, 60 * S), 2))
        y0 = rng.randint(S, 30 * S)
        y1 = y0 + rng.randint(0, min(x1 - x0, 30 * S))
        st = setup(config, Edge(x0, y0, x1, y1, "left", 255, 0))
        p = st.pieces
        if st.columns < 2:
            continue
        K = Fraction(st.kq * st.du + st.kr, st.du)
        g = Fraction(x0, S) - (math.floor(Fraction(x0 * 2 + S, 2 * S)) - Fraction(1, 2))
        e = (math.ceil(Fraction(x1 * 2 - S, 2 * S)) + Fraction(1, 2)) - Fraction(x1, S)
        worst = max(
            worst, abs(p.total0 - K * (1 - g) ** 2 / 2), abs(p.total1 - K * (1 - e * e) / 2)
        )
    check(
        "x-major totals K(1-g)^2/2 and K(1-e^2)/2 within 3/2 units",
        worst < Fraction(3, 2),
        f"{float(worst):.3f}",
    )


def part_d_pixel_bound() -> None:
    section("D4. every pixel within the sum of its edges' bounds (13.6)")
    from edgeaa.render import Polygon, Scene, render_scene
    from edgeaa.render.exact import edges_per_pixel, exact_image

    rng = random.Random(8)
    worst_ratio, pixels = 0.0, 0
    for mode in ("paper", "seg4"):
        config = EdgeConfig(mode=mode)
        for trial in range(12):
            n = 3 if trial % 2 else rng.randint(5, 9)
            pts = tuple((rng.uniform(1, 30), rng.uniform(1, 30)) for _ in range(n))
            scene = Scene(32, 32, (Polygon((pts,), 255, "evenodd"),), background=0)
            result = render_scene(scene, config)
            err = np.abs(result.image - exact_image(result.plan))
            crossers = edges_per_pixel(result)
            # c_N k <= c_N per edge; a few units of fixed point, half an LSB of rounding
            bound = crossers * float(C_N[mode]) * 255 + 0.5 + 0.01
            worst_ratio = max(worst_ratio, float((err / bound).max()))
            pixels += err.size
    check(
        "|error| <= sum of c_N |I_d| over crossing edges + 1/2 LSB",
        worst_ratio <= 1,
        f"max ratio {worst_ratio:.3f} over {pixels} pixels",
    )


def _stroke_error(config: EdgeConfig, offset: float, width: float) -> tuple[float, float]:
    """Max error (LSB) and the bound of section 13.6 over the pixels of a 45-degree stroke
    (a parallelogram: two parallel edges of opposite winding through the same pixels)."""
    from edgeaa.render import Polygon, Scene, render_scene
    from edgeaa.render.exact import edges_per_pixel, exact_image

    y0 = 2 + offset
    pts = ((2.0, y0), (30.0, y0 + 28), (30.0, y0 + 28 + width), (2.0, y0 + width))
    result = render_scene(Scene(34, 34, (Polygon((pts,), 255),)), config)
    err = np.abs(result.image - exact_image(result.plan))
    crossers = edges_per_pixel(result)
    worst = np.unravel_index(np.argmax(err), err.shape)
    bound = crossers[worst] * float(C_N[config.mode]) * 255 + 0.5 + 0.01
    return float(err[worst]), bound


def part_d_two_edges() -> None:
    section("D6. two edges in one pixel: their estimate errors add (13.6)")
    paper = EdgeConfig(mode="paper")
    worst, bound = _stroke_error(paper, 0.25, 1.0)
    check(
        "paper, 45-degree stroke 1 px wide at offset 1/4: past 5 LSB, within 2 c_N |I_d| + 1/2",
        5 < worst <= bound,
        f"{worst:.2f} LSB, bound {bound:.2f}",
    )
    # The same stroke with the exact triangle in place of the add-only estimate: the excess is
    # the estimate's alone, the accumulation adds only the output rounding.
    estimate = column_module.triangle_estimate

    def exact_triangle(a, config, st, dq, where=True):
        dq = np.asarray(dq, dtype=np.float64)
        t = np.floor(dq * dq / (2 * np.maximum(st.kq, 1)) + 0.5).astype(np.int64)
        return t if t.ndim else int(t)

    column_module.triangle_estimate = exact_triangle
    try:
        exact_worst, _ = _stroke_error(paper, 0.25, 1.0)
    finally:
        column_module.triangle_estimate = estimate
    check(
        "the same stroke with the exact triangle: output rounding only",
        exact_worst <= 0.51,
        f"{exact_worst:.2f} LSB",
    )
    seg2_worst, seg2_bound = _stroke_error(EdgeConfig(mode="seg2"), 0.25, 1.0)
    check(
        "seg2 on the same stroke: within its bound",
        seg2_worst <= seg2_bound,
        f"{seg2_worst:.2f} LSB, bound {seg2_bound:.2f}",
    )


def part_d_fill() -> None:
    section("D5. fill rules on sums (13.7)")
    from edgeaa.model.accumulate import fill

    sums = np.array([0, 5, 10, -10, 15, 20, 25, -25, 30])
    check(
        "non-zero: min(|S|, ifix)",
        fill(sums, "nonzero", 10).tolist() == [0, 5, 10, 10, 10, 10, 10, 10, 10],
    )
    check(
        "even-odd: folded with period 2 ifix",
        fill(sums, "evenodd", 10).tolist() == [0, 5, 10, 10, 5, 0, 5, 5, 10],
    )


def part_d_units_per_edge() -> None:
    section("D7. units one edge adds to a polygon's pixel, F at its floor, |I_d| = 1 (13.6)")
    from edgeaa.render import Polygon, Scene, render_scene
    from edgeaa.render.exact import edges_per_pixel, sum_errors

    rng = random.Random(5)
    worst, uncrossed, pixels = 0.0, 0.0, 0
    for mode in ("paper", "seg4"):
        config = EdgeConfig(mode=mode, frac_bits=EdgeConfig(mode=mode).min_frac_bits)
        for _ in range(60):
            size = rng.choice((8, 16, 32))
            n = rng.choice((3, 4, 5, 7, 9))
            pts = tuple(
                (rng.uniform(0.5, size - 0.5), rng.uniform(0.5, size - 0.5)) for _ in range(n)
            )
            rule = rng.choice(("nonzero", "evenodd"))
            scene = Scene(size, size, (Polygon((pts,), 1, rule),), background=0)
            result = render_scene(scene, config, skip=False)
            err = sum_errors(result)  # units: |I_d| = 1, so 2^-F of a pixel each
            crossers = edges_per_pixel(result)
            crossed = crossers > 0
            worst = max(worst, float((err[crossed] / crossers[crossed]).max(initial=0)))
            uncrossed = max(uncrossed, float(err[~crossed].max(initial=0)))
            pixels += err.size
    check(
        f"|sum - exact| / crossing edges < {UNITS_PER_EDGE} units (estimate included)",
        worst < UNITS_PER_EDGE,
        f"max {worst:.3f} units over {pixels} pixels",
    )
    check("pixels no edge crosses: exact", uncrossed < 1e-9, f"max {uncrossed:.2g} units")


def part_d_beat_clocks() -> None:
    section("D8. the accumulator's clocks of an edge's beats (docs/hardware.md, clock estimate)")
    from edgeaa.model.beat import delta_beats_to_array, delta_column_beats
    from edgeaa.model.step import run_edge_deltas
    from edgeaa.model.tile import TileConfig, beat_clocks

    config, tile = EdgeConfig(), TileConfig()
    S, top = config.subpixel_scale, config.max_vertex
    rng = random.Random(8)
    worst = {1: 0.0, 2: 0.0}
    edges = 0
    for _ in range(3000):
        length = rng.choice((1, 3, 10, 60, 400)) * S
        x0, y0 = rng.randrange(length, top - length), rng.randrange(length, top - length)
        angle = rng.uniform(0, 2 * math.pi)
        x1, y1 = round(x0 + length * math.cos(angle)), round(y0 + length * math.sin(angle))
        edge = Edge(x0, y0, x1, y1, rng.choice(("left", "right")), rng.randrange(1, 256))
        try:
            columns = run_edge_deltas(config, edge)
        except EdgeError:
            continue
        if not columns:
            continue
        cells = delta_beats_to_array(delta_column_beats(columns))[:, :12].reshape(-1, 4, 3)
        dx, dy = abs(x1 - x0), abs(y1 - y0)
        minor = math.ceil(len(columns) * min(dx, dy) / max(dx, dy, 1))
        origin = (min(x0, x1) // S - 1, min(y0, y1) // S - 1)
        for lanes in (1, 2):
            clocks = int(beat_clocks(cells, lanes, tile, origin).sum())
            worst[lanes] = max(worst[lanes], clocks / ((2 // lanes) * (len(columns) + minor)))
        edges += 1
    for lanes in (1, 2):
        check(
            f"{lanes} scan lane(s): clocks <= {2 // lanes} (beats + ceil(beats * slope))",
            worst[lanes] <= 1,
            f"max {worst[lanes]:.3f} of the bound over {edges} edges",
        )


def booth_final(s: int, w0: int, m: int, width: int) -> tuple[int, int]:
    """FINAL's ``y_area0`` after its clocks (`edgeaa.hdl.pieces.total0_steps`, Booth radix
    4, modulo ``2**width``) and the first clock's multiplier."""
    digits = (s + 3) // 2
    bits = [0] + [(w0 >> i) & 1 for i in range(2 * digits)]  # b[-1] = 0 at index 0
    mask, y, first = (1 << width) - 1, 0, None
    for clock in range(digits):
        j = digits - 1 - clock
        low, mid, top = bits[2 * j], bits[2 * j + 1], bits[2 * j + 2]
        if clock == 0:  # 2 t + h + l, selected from 0, M, 2 M
            first = 2 * top + mid + low
            y = ((m << 1) if top or (mid and low) else (m if mid ^ low else 0)) & mask
            continue
        twice = (not mid and not low) if top else (mid and low)
        magnitude = ((m << 1) if twice else (m if mid ^ low else 0)) & mask
        y = ((y << 2) + ((~magnitude & mask) if top else magnitude) + top) & mask
    return y, first


def part_d_exact_rewrites() -> None:
    section("D9. exact rewrites in the hardware (docs/hardware.md, compact's long paths)")
    rng = random.Random(9)
    bad, firsts, cases = 0, set(), 0
    for s in range(7):
        for w0 in range(2 * (1 << s) + 1):  # 0 <= w0 <= 2 S
            for _ in range(8):
                width = rng.randrange(s + 3, 40)
                m = rng.randrange(1 << width)
                y, first = booth_final(s, w0, m, width)
                bad += y != (m * w0) % (1 << width)
                firsts.add(first)
                cases += 1
    check(
        "Booth FINAL: y_area0 = M w0 mod 2^width, s = 0..6, every w0 <= 2 S",
        bad == 0,
        f"{cases} cases",
    )
    check(
        "Booth FINAL: the first clock's multiplier is 0, 1 or 2",
        firsts <= {0, 1, 2},
        f"seen {sorted(firsts)}",
    )
    bad = 0
    for _ in range(20000):
        bits, wa, wb = rng.randrange(1, 20), rng.randrange(1, 24), rng.randrange(1, 24)
        a, b = rng.randrange(-(1 << wa), 1 << wa), rng.randrange(-(1 << wb), 1 << wb)
        if rng.random() < 0.3:
            b = a + rng.choice((0, 1 << bits, -(1 << bits)))
        nonzero = ((a ^ b) & ((1 << bits) - 1)) != 0  # a ^ b's low bits
        bad += nonzero != (((a - b) % (1 << bits)) != 0)
    check("nonzero flag: a ^ b in the payload's bits <=> (a - b) mod 2^bits != 0", bad == 0)
    part_d_piece_end_rewrites(rng)


def part_d_piece_end_rewrites(rng: random.Random) -> None:
    """The deltas stepper's piece end in one carry chain and its depth less the intercept in
    one add (hdl/deltas.py `_piece_end`, `_depth`)."""
    bad = 0
    for _ in range(20000):
        w, wq = rng.randrange(1, 16), rng.randrange(1, 20)
        du = rng.randrange(1, 1 << w)
        jr, khr = rng.randrange(du), rng.randrange(du)
        jq, khq = rng.randrange(1 << wq), rng.randrange(1 << wq)
        chain = ((jq << w) + jr + (khq << w) + ((khr - du) % (1 << w))) >> w
        bad += chain != jq + khq + (jr + khr >= du)
    check(
        "piece end: Cat(jr, jq) + Cat(khr - du mod 2^w, khq) >> w = jq + khq + [jr+khr >= du]",
        bad == 0,
    )
    bad = 0
    for _ in range(20000):
        hb, ib, cb = rng.randrange(2, 22), rng.randrange(1, 20), rng.randrange(1, 14)
        he, hs = (rng.randrange(-(1 << (hb - 1)), 1 << (hb - 1)) for _ in range(2))
        ifix, icpt = rng.randrange(1 << ib), rng.randrange(1 << cb) << 2
        width = max(max(hb, ib + 1) + 1, cb + 2) + 1  # _depth_width, then the intercept's
        low = rng.random() < 0.5
        mask = (1 << width) - 1
        operand = he if low else ~hs
        sub = (ifix + icpt) & mask if low else (icpt - 1) & mask
        got = (operand + (~sub & mask) + 1) & mask
        # the bits of the add it replaces, (depth - icpt) cut to the same width
        bad += got != (((he - ifix) if low else -hs) - icpt) & mask
    check(
        "depth less intercept: X + ~D + 1 = (he - ifix or -hs) - icpt mod 2^width, D per edge",
        bad == 0,
    )


def part_d() -> None:
    part_d_split_tables()
    part_d_no_leak()
    part_d_end_totals()
    part_d_pixel_bound()
    part_d_two_edges()
    part_d_units_per_edge()
    part_d_fill()
    part_d_beat_clocks()
    part_d_exact_rewrites()


def main() -> int:
    start = time.time()
    np.seterr(divide="ignore", invalid="ignore")
    part_a()
    part_b()
    part_c()
    part_d()
    print(f"\n{len(FAILED)} failed checks; {time.time() - start:.1f} s")
    for name in FAILED:
        print(f"  FAILED: {name}")
    return 1 if FAILED else 0


if __name__ == "__main__":
    sys.exit(main())
