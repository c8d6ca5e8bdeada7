"""Edge commands and the per-edge setup: octant folding, increments and the initial value.

Everything here runs once per edge; it may multiply and divide (the hardware uses a
sequential divider). The per-column loop in `step.py` uses only what `setup` returns.
The arithmetic after validation is written once (`setup_fields`, on an arithmetic like
`edgeaa.model.column`'s): `setup` runs it on one edge's ints, `setup_batch` on numpy arrays
of many edges (a `SetupBatch`, equal to `setup` of each).
Coordinates are image coordinates (x right, y down, pixel (x, y) centred on integers) in
sub-pixel units: a vertex coordinate X means X / 2**subpixel_bits pixels.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, fields
from fractions import Fraction
from typing import Any, NamedTuple

import numpy as np

from .column import ArrayArith, IntArith
from .config import EdgeConfig
from .numbers import decimal

INSIDE_SIDES = ("left", "right")


class EdgeError(ValueError):
    """An edge command the configured antialiaser cannot draw."""


class Clip(NamedTuple):
    """A clip window in whole pixels, bounds included: the core steps only the columns whose
    major-axis pixel lies inside it (x_min .. x_max for an x-major edge, y_min .. y_max for a
    y-major one). The minor axis is not clipped: a write may still land outside the window.
    Each bound is in [0, 2**coord_bits]; a window with min > max steps no column."""

    x_min: int
    y_min: int
    x_max: int
    y_max: int

    @classmethod
    def full(cls, config: EdgeConfig) -> Clip:
        """The window that clips nothing: every pixel a vertex in range can reach."""
        top = 1 << config.coord_bits
        return cls(0, 0, top, top)

    @classmethod
    def from_port(cls, config: EdgeConfig, x_min, y_min, x_max, y_max) -> Clip:
        """The window the core steps for any value of its ``clip`` ports, which are
        ``coord_bits + 1`` bits wide and so carry bounds up to ``2**(coord_bits + 1) - 1``,
        past the model's [0, 2**coord_bits]. Columns lie in [0, 2**coord_bits] on either
        axis, so a max above ``2**coord_bits`` acts as ``2**coord_bits``, and a min above it
        leaves that axis no column: the window (1, 0) on it (empty stepping up or down).
        Bounds in range are returned unchanged (`window` computes the same columns from
        either)."""
        top, port_max = 1 << config.coord_bits, (1 << (config.coord_bits + 1)) - 1
        bounds = (x_min, y_min, x_max, y_max)
        for name, value in zip(cls._fields, bounds, strict=True):
            if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= port_max:
                raise EdgeError(
                    f"clip port {name} must be an integer in [0, {port_max}] "
                    f"(coord_bits + 1 = {config.coord_bits + 1} bits), not {value!r}"
                )
        axes = []
        for low, high in ((x_min, x_max), (y_min, y_max)):
            axes.append((1, 0) if low > top else (low, min(high, top)))
        (x_lo, x_hi), (y_lo, y_hi) = axes
        return cls(x_lo, y_lo, x_hi, y_hi)


@dataclass(frozen=True)
class Edge:
    """One edge command: P0 -> P1 in sub-pixel units, the inside side and two intensities.

    inside is the side of the direction of travel P0 -> P1 (as seen on the image, y down) that
    gets i_in; the other side gets i_out. i_in None means full scale. clip None means
    `Clip.full` (in the hardware, the ``clip`` port's value in the clock the edge is accepted).
    """

    x0: int
    y0: int
    x1: int
    y1: int
    inside: str = "left"
    i_in: int | None = None
    i_out: int = 0
    clip: Clip | None = None

    @classmethod
    def from_pixels(cls, config: EdgeConfig, x0, y0, x1, y1, **kwargs) -> Edge:
        """Build an edge from pixel coordinates (numbers or strings like '10.25')."""
        scale = config.subpixel_scale
        fixed = []
        for name, value in zip(("X0", "Y0", "X1", "Y1"), (x0, y0, x1, y1), strict=True):
            exact = _number(name, value) * scale
            if exact.denominator != 1:
                raise EdgeError(
                    f"{name} = {value} is not a multiple of the sub-pixel step "
                    f"1/{scale} (subpixel_bits = {config.subpixel_bits})"
                )
            fixed.append(int(exact))
        return cls(*fixed, **kwargs)

    def intensities(self, config: EdgeConfig) -> tuple[int, int]:
        i_in = config.full_scale if self.i_in is None else self.i_in
        return i_in, self.i_out

    def window(self, config: EdgeConfig) -> Clip:
        return Clip.full(config) if self.clip is None else Clip(*self.clip)


def _number(name: str, value) -> Fraction:
    """A coordinate exactly: text through `decimal` (Fraction('1e1000000000') would build the
    power), anything else through Fraction."""
    if isinstance(value, str):
        try:
            return decimal(value)
        except ValueError as error:
            raise EdgeError(f"{name} {error}") from None
    try:
        return Fraction(value)
    except (ValueError, TypeError, ZeroDivisionError):
        raise EdgeError(f"{name} must be a number, not {value!r}") from None


def validate(config: EdgeConfig, edge: Edge) -> None:
    """Raise EdgeError naming what is wrong with the edge and what is allowed."""
    hi = config.max_vertex
    scale = config.subpixel_scale
    for name in ("x0", "y0", "x1", "y1"):
        value = getattr(edge, name)
        if isinstance(value, bool) or not isinstance(value, int):
            raise EdgeError(f"{name.upper()} must be an integer in sub-pixel units, not {value!r}")
        if not 0 <= value <= hi:
            raise EdgeError(
                f"{name.upper()} = {value / scale:g} px is outside the configured range "
                f"[0, {hi / scale}] px (coord_bits = {config.coord_bits}, "
                f"subpixel_bits = {config.subpixel_bits})"
            )
    if edge.x0 == edge.x1 and edge.y0 == edge.y1:
        raise EdgeError("zero-length edge: P0 and P1 are the same point")
    if edge.clip is not None:
        validate_clip(config, edge.clip)
    if edge.inside not in INSIDE_SIDES:
        raise EdgeError(f"inside must be 'left' or 'right', not {edge.inside!r}")
    i_in, i_out = edge.intensities(config)
    for name, value in (("I_in", i_in), ("I_out", i_out)):
        if (
            isinstance(value, bool)
            or not isinstance(value, int)
            or not (0 <= value <= config.full_scale)
        ):
            raise EdgeError(
                f"{name} must be an integer in [0, {config.full_scale}] "
                f"(intensity_bits = {config.intensity_bits}), not {value!r}"
            )
    if i_in == i_out:
        # The evaluation function is scaled by I_in - I_out; at zero it cannot choose pixels.
        raise EdgeError(
            f"I_in equals I_out ({i_in}): the edge has nothing to antialias; "
            "draw its pixels with the fill instead"
        )


def validate_clip(config: EdgeConfig, clip) -> None:
    """Raise EdgeError unless `clip` is four integer pixel bounds in [0, 2**coord_bits]."""
    top = 1 << config.coord_bits
    if not isinstance(clip, tuple) or len(clip) != 4:
        raise EdgeError(f"clip must be (x_min, y_min, x_max, y_max) in pixels, not {clip!r}")
    for name, value in zip(Clip._fields, clip, strict=True):
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= top:
            raise EdgeError(
                f"clip {name} must be an integer pixel in [0, {top}] "
                f"(coord_bits = {config.coord_bits}), not {value!r}"
            )


@dataclass(frozen=True)
class EdgeSetup:
    """Per-edge constants and the initial state of the stepping loop (see docs/model.md)."""

    x_major: bool
    columns: int  # columns to step: those inside the clip window (0: nothing to step)
    clipped_start: bool  # the window moved the first column: the setup's long pass (timing)
    x: int  # screen pixel of the first column's primary write
    y: int
    col_dx: int  # screen step of one column (along the major axis)
    col_dy: int
    row_dx: int  # screen step of one row (along the minor axis, the stepping direction)
    row_dy: int
    du: int  # |major delta| in sub-pixel units: the remainder modulus
    dv: int  # |minor delta|
    ifix: int  # |I_in - I_out| << F
    jq: int  # initial accumulator, quotient and remainder
    jr: int
    kq: int  # per-column increment
    kr: int
    khq: int  # half increment (the exit threshold k/2)
    khr: int
    value_base: int  # intensity of the B side (coverage of A = 0)
    value_sign: int  # +1 if the A side is brighter, else -1
    inside_is_a: bool  # the A side (towards smaller minor coordinate) is inside
    seg_thresholds: tuple[int, ...]  # segment j starts at d >= seg_thresholds[j - 1]
    seg_intercepts: tuple[int, ...]  # subtracted from the slope term on segment j
    pieces: EndPieces | None = None  # the accumulation constants (`end_pieces`)

    @property
    def major_neg_x(self) -> bool:
        """An x-major edge that steps left (its column pair's values swap on screen)."""
        return self.x_major and self.col_dx < 0

    @property
    def k(self) -> Fraction:
        return Fraction(self.dv, self.du)

    @property
    def remaining(self) -> int:
        """Columns still to step after the first (the bank's count; -1: none to step)."""
        return self.columns - 1


def floor_div(a: int, b: int) -> int:
    return a // b  # Python floors toward -inf for negative numerators too


def segment_constants(config: EdgeConfig, kq: int) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """Thresholds j*K/(2N) and intercepts K*(8j(j+1)+1)/(64N^2) of the N-segment estimate."""
    n = config.segments
    if n == 0:
        return (), ()
    log2n = n.bit_length() - 1
    thresholds = tuple((j * kq) >> (log2n + 1) for j in range(1, n))
    intercepts = tuple(((8 * j * (j + 1) + 1) * kq) >> (6 + 2 * log2n) for j in range(n))
    return thresholds, intercepts


@dataclass
class Fold:
    """An edge folded into the first octant: u along the major axis and v along the minor,
    both increasing (`fold`). Fields are ints and bools in the model, values in the formal
    specification."""

    x_major: Any  # |dx| >= |dy|
    major_neg: Any  # the major axis steps down (u = -p)
    minor_neg: Any  # the minor axis steps down (v = -q)
    u0: Any  # folded coordinates of P0 and P1, sub-pixel units
    v0: Any
    u1: Any
    du: Any  # |major delta|, the remainder modulus
    dv: Any  # |minor delta|
    c0: Any  # first and last column whose interior the edge's projection overlaps
    c1: Any
    inside_is_a: Any  # the inside is the A side (towards smaller v)
    i_d: Any  # |I_in - I_out|
    value_base: Any  # I_B, the intensity at zero A-side coverage
    value_neg: Any  # I_A < I_B: the value falls as the A-side area grows


def fold(a, config: EdgeConfig, x0, y0, x1, y1, i_in, i_out, inside_left) -> Fold:
    """Fold an edge command into the first octant (`edgeaa.model.column` explains `a`).

    The columns are those whose interior the projection overlaps: floor(u0 + 1/2) ..
    ceil(u1 - 1/2). A swap of the axes or one mirror flips left and right (det)."""
    s, S = config.subpixel_bits, config.subpixel_scale
    dx, dy = x1 - x0, y1 - y0
    adx, ady = a.select(dx < 0, -dx, dx), a.select(dy < 0, -dy, dy)
    x_major = adx >= ady
    major_neg = a.select(x_major, dx, dy) <= 0
    minor_neg = a.select(x_major, dy, dx) < 0
    p0, q0, p1 = a.select(x_major, x0, y0), a.select(x_major, y0, x0), a.select(x_major, x1, y1)
    u0, u1 = a.select(major_neg, -p0, p0), a.select(major_neg, -p1, p1)
    diff = i_in - i_out
    # det = +1: the folding map keeps orientation; then the left of travel is the A side.
    det_pos = x_major ^ major_neg ^ minor_neg
    inside_is_a = inside_left == det_pos
    i_a, i_b = a.select(inside_is_a, i_in, i_out), a.select(inside_is_a, i_out, i_in)
    return Fold(
        x_major=x_major,
        major_neg=major_neg,
        minor_neg=minor_neg,
        u0=u0,
        v0=a.select(minor_neg, -q0, q0),
        u1=u1,
        du=a.select(x_major, adx, ady),
        dv=a.select(x_major, ady, adx),
        c0=((u0 << 1) + S) >> (s + 1),
        c1=-((S - (u1 << 1)) >> (s + 1)),
        inside_is_a=inside_is_a,
        i_d=a.select(diff < 0, -diff, diff),
        value_base=i_b,
        value_neg=i_a < i_b,
    )


@dataclass
class Window:
    """A folded edge's columns cut to the clip window along the major axis (`window`)."""

    lo: Any  # the window's major-axis bounds, folded like u
    hi: Any
    start_clip: Any  # the window moved the first column: c0 < lo
    first: Any  # max(c0, lo)
    last: Any  # min(c1, hi); none visible when last < first


def window(a, folded: Fold, clip) -> Window:
    """Cut the columns c0 .. c1 to the clip window's major-axis bounds (x_min .. x_max for an
    x-major edge), which fold like u: (min, max), or (-max, -min) when the axis steps down."""
    neg = folded.major_neg
    lo = a.select(
        folded.x_major,
        a.select(neg, -clip.x_max, clip.x_min),
        a.select(neg, -clip.y_max, clip.y_min),
    )
    hi = a.select(
        folded.x_major,
        a.select(neg, -clip.x_min, clip.x_max),
        a.select(neg, -clip.y_min, clip.y_max),
    )
    start_clip = folded.c0 < lo
    first = a.select(start_clip, lo, folded.c0)
    last = a.select(folded.c1 > hi, hi, folded.c1)
    return Window(lo=lo, hi=hi, start_clip=start_clip, first=first, last=last)


@dataclass(frozen=True)
class EndPieces:
    """What the accumulation deltas (`edgeaa.model.column.column_deltas`) need beyond the
    stepping constants: the edge's own piece in its first and last column, cut at the
    vertices, and its winding sign. Heights are in units of ifix per pixel, measured from
    the top (smaller v) of the stepping loop's row; docs/algorithm.md section 13 derives each.

    An end column is *partial* when it holds a vertex (not cut away by the clip window);
    a one-column edge is partial at both ends and ``total0``, ``band0`` describe its whole
    piece. x-major edges use total (the piece's area on the +u side of the line) and rect
    (the rectangle between the crossing part and the column's far side); y-major edges use
    total (the piece's integral of height) and band (ifix times the piece's width)."""

    sigma: int  # +1: the cells on the +x side of the edge gain coverage; -1: they lose it
    row0: int  # folded row of the first column (the loop's row register starts here)
    first_partial: bool
    last_partial: bool
    hs0: int  # height where the first column's piece starts
    end_row: int  # folded row holding P1
    end_height: int  # P1's height above its row's top, in [0, ifix)
    total0: int
    total1: int
    rect0: int
    rect1: int
    band0: int
    band1: int


def end_pieces(
    config: EdgeConfig, f: Fold, w: Window, st_values: dict, inside_left, a=None
) -> EndPieces:
    """The per-edge constants of `EndPieces` (divisions and small products: setup only).

    st_values holds the setup's columns, row0 (folded), jq, jr, kq, khq, khr, du, i_d and
    the edge's screen dy. `a` is the arithmetic (`edgeaa.model.column`): ints by default,
    or `ArrayArith` for a batch (every branch is computed, then selected)."""
    a = _SELECTS if a is None else a
    s, F, S = config.subpixel_bits, config.F, config.subpixel_scale
    v = st_values
    columns, row0, i_d, du = v["columns"], v["row0"], v["i_d"], v["du"]
    jq, jr, khq, khr = v["jq"], v["jr"], v["khq"], v["khr"]
    ifix = i_d << F
    half = i_d << (F - s - 1)  # ifix per half sub-pixel step (F > s: exact)
    first_partial = (columns > 0) & a.not_(w.start_clip)
    last_partial = (columns > 0) & (w.last == f.c1)
    single = (columns == 1) & first_partial & last_partial
    # In half sub-pixel steps (2 S per pixel, so that a pixel's edges are whole numbers):
    mg = a.select(first_partial, 2 * f.u0 - (2 * w.first - 1) * S, 0)  # column start to u0
    me = a.select(last_partial, (2 * w.last + 1) * S - 2 * f.u1, 0)  # from u1 to column end
    v1 = f.v0 + f.dv  # folded, both axes increase from P0 to P1
    hs0 = a.select(
        first_partial,
        half * (2 * f.v0 - (2 * row0 - 1) * S),
        jq - khq - a.select(jr < khr, 1, 0),  # a whole column: floor(J - K/2)
    )
    end_row = (2 * v1 + S) >> (s + 1)
    end_height = half * (2 * v1 - (2 * end_row - 1) * S)
    he_first = a.select(  # floor(J + K/2) of the first column, or P1's height in it
        single,
        end_height + (end_row - row0) * ifix,
        jq + khq + a.select(jr + khr >= du, 1, 0),
    )
    ends = dict(mg=mg, me=me, single=single, hs0=hs0, he_first=he_first, end_height=end_height)
    areas = _piece_areas(a, config, f.x_major, v["kq"], half, ends)
    # Travelling down the screen with the inside on the left puts the inside on the +x side.
    sigma = a.select((v["dy"] > 0) == inside_left, 1, -1)
    return EndPieces(
        sigma, row0, first_partial, last_partial, hs0, end_row, end_height, **areas
    )  # fmt: skip


def _piece_areas(a, config: EdgeConfig, x_major, kq, half, e: dict) -> dict:
    """total, rect and band of the end pieces (`EndPieces`), both axes computed and the
    edge's selected. Areas of partial pieces use K's quotient kq: within one unit, and no new
    division."""
    s, S = config.subpixel_bits, config.subpixel_scale
    mg, me, single, hs0, end_height = e["mg"], e["me"], e["single"], e["hs0"], e["end_height"]
    sq = 2 * s + 3  # K w^2 / 2 with w over 2 S: (kq w^2) >> (2 s + 3)
    me_single = a.select(single, me, 0)
    w0 = 2 * S - mg - me_single  # the first piece's width, 2 S per pixel
    w1 = 2 * S - me
    # x-major: the piece's area on the +u side, and the rectangles beyond the crossing part
    total0_x = (kq * ((2 * S - mg) ** 2 - me_single * me_single)) >> sq
    total1_x = (kq * (4 * S * S - me * me)) >> sq
    rect0 = (a.select(hs0 < 0, -hs0, 0) * mg) >> (s + 1)
    rect1 = (end_height * me) >> (s + 1)
    # y-major: the piece's integral of height, and ifix times its width
    total0_y = ((hs0 + e["he_first"]) * w0) >> (s + 2)
    total1_y = ((end_height * w1) >> (s + 1)) - ((kq * w1 * w1) >> sq)
    return dict(
        total0=a.select(x_major, total0_x, total0_y),
        total1=a.select(x_major, total1_x, total1_y),
        rect0=a.select(x_major, rect0, 0),
        rect1=a.select(x_major, rect1, 0),
        band0=a.select(x_major, 0, half * w0),
        band1=a.select(x_major, 0, half * w1),
    )


_SELECTS = IntArith()


def setup(config: EdgeConfig, edge: Edge) -> EdgeSetup:
    """Fold the edge into the first octant and compute the loop's constants and start state."""
    validate(config, edge)
    i_in, i_out = edge.intensities(config)
    values = setup_fields(
        _SELECTS,  # ints: fold and window only select, no register is checked here
        config,
        edge.x0,
        edge.y0,
        edge.x1,
        edge.y1,
        edge.inside == "left",
        i_in,
        i_out,
        edge.window(config),
    )
    return EdgeSetup(**values)


def setup_fields(a, config: EdgeConfig, x0, y0, x1, y1, inside_left, i_in, i_out, clip) -> dict:
    """`EdgeSetup`'s fields by name, written once for `setup` (`a` on ints, one edge) and
    `setup_batch` (`ArrayArith`, one element per edge): every branch is a select."""
    F = config.F
    f = fold(a, config, x0, y0, x1, y1, i_in, i_out, inside_left)
    w = window(a, f, clip)
    start = _start(a, config, f, w)
    inc = _increments(config, f, start["mf"])
    thresholds, intercepts = segment_constants(config, inc["kq"])
    x_major = f.x_major
    step_major, step_minor = a.select(f.major_neg, -1, 1), a.select(f.minor_neg, -1, 1)
    c0, row0 = start["c0"], start["row0"]
    values = dict(columns=start["columns"], row0=row0, du=f.du, i_d=f.i_d, dy=y1 - y0, **inc)
    return dict(
        x_major=x_major,
        columns=start["columns"],
        clipped_start=start["clipped_start"],
        x=a.select(x_major, step_major * c0, step_minor * row0),
        y=a.select(x_major, step_minor * row0, step_major * c0),
        col_dx=a.select(x_major, step_major, 0),
        col_dy=a.select(x_major, 0, step_major),
        row_dx=a.select(x_major, 0, step_minor),
        row_dy=a.select(x_major, step_minor, 0),
        du=f.du,
        dv=f.dv,
        ifix=f.i_d << F,
        **inc,
        value_base=f.value_base,
        value_sign=a.select(f.value_neg, -1, 1),
        inside_is_a=f.inside_is_a,
        seg_thresholds=thresholds,
        seg_intercepts=intercepts,
        pieces=end_pieces(config, f, w, values, inside_left, a),
    )


def _start(a, config: EdgeConfig, f: Fold, w: Window) -> dict:
    """The columns to step and the first column's row: row0, and mf, where the line crosses
    that column's centre within the row."""
    S = config.subpixel_scale
    span = w.last - w.first + 1
    columns = a.select(span > 0, span, 0)
    clipped_start = (columns > 0) & w.start_clip
    c0 = a.select(columns > 0, w.first, f.c0)  # an empty cut keeps c0
    # Line height at the centre of column c0: vc = num / den pixels.
    num = f.v0 * f.du + f.dv * (c0 * S - f.u0)
    den = S * f.du
    row0 = floor_div(2 * num + den, 2 * den)  # row whose span [y - 1/2, y + 1/2) holds vc
    mf = 2 * num + den - 2 * row0 * den  # f = vc - (row0 - 1/2) = mf / (2 den), in [0, 1)
    return dict(columns=columns, clipped_start=clipped_start, c0=c0, row0=row0, mf=mf)


def _increments(config: EdgeConfig, f: Fold, mf) -> dict:
    """The accumulator's start J, increment K and half increment K/2, each a quotient and a
    remainder over du (remainders dropped by the truncated accumulator)."""
    s, F = config.subpixel_bits, config.F
    i_d, du = f.i_d, f.du
    jq, jr = _divmod(i_d * mf << (F - s - 1), du)
    kq, kr = _divmod(i_d * f.dv << F, du)
    khq, khr = _divmod(i_d * f.dv << (F - 1), du)
    if config.accumulator == "truncated":
        jr, kr, khr = 0 * jr, 0 * kr, 0 * khr  # the paper's fixed point; zeros of jr's kind
    return dict(jq=jq, jr=jr, kq=kq, kr=kr, khq=khq, khr=khr)


def _divmod(n, d):
    """Floor quotient and remainder of ints, int64 arrays or object arrays alike (np.divmod
    has no object-array loop)."""
    q = n // d
    return q, n - q * d


# -- many edges at once ------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class SetupBatch:
    """`EdgeSetup` of a batch of edges as a struct of arrays, one element per edge
    (`setup_batch`): the flags as bool arrays, the rest int64 arrays, or object arrays of
    Python ints where int64 could overflow; `seg_thresholds` and `seg_intercepts` tuples of
    arrays (one per segment); `pieces` an `EndPieces` whose fields are such arrays.
    ``batch[k]`` is edge k's `EdgeSetup`, equal to `setup` of it."""

    x_major: np.ndarray
    columns: np.ndarray
    clipped_start: np.ndarray
    x: np.ndarray
    y: np.ndarray
    col_dx: np.ndarray
    col_dy: np.ndarray
    row_dx: np.ndarray
    row_dy: np.ndarray
    du: np.ndarray
    dv: np.ndarray
    ifix: np.ndarray
    jq: np.ndarray
    jr: np.ndarray
    kq: np.ndarray
    kr: np.ndarray
    khq: np.ndarray
    khr: np.ndarray
    value_base: np.ndarray
    value_sign: np.ndarray
    inside_is_a: np.ndarray
    seg_thresholds: tuple[np.ndarray, ...]
    seg_intercepts: tuple[np.ndarray, ...]
    pieces: EndPieces

    def __len__(self) -> int:
        return len(self.columns)

    def __getitem__(self, k: int) -> EdgeSetup:
        values = {
            f.name: _scalar(getattr(self, f.name), k)
            for f in fields(EdgeSetup)
            if f.name != "pieces"
        }
        values["pieces"] = EndPieces(
            *(_scalar(getattr(self.pieces, f.name), k) for f in fields(EndPieces))
        )
        return EdgeSetup(**values)

    def __iter__(self) -> Iterator[EdgeSetup]:
        return (self[k] for k in range(len(self)))

    def take(self, index) -> SetupBatch:
        """The setups of the edges `index` (a slice or an array of indices), in that order."""
        values = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name != "pieces":
                values[f.name] = (
                    tuple(a[index] for a in value) if isinstance(value, tuple) else value[index]
                )
        pieces = EndPieces(*(getattr(self.pieces, f.name)[index] for f in fields(EndPieces)))
        return SetupBatch(**values, pieces=pieces)

    @property
    def major_neg_x(self) -> np.ndarray:
        """x-major edges that step left (`EdgeSetup.major_neg_x`)."""
        return self.x_major & (self.col_dx < 0)

    @classmethod
    def from_setups(cls, config: EdgeConfig, setups: Sequence[EdgeSetup]) -> SetupBatch:
        """The struct of arrays of `setup`'s results (one list per field)."""
        values = {
            f.name: _stack([getattr(st, f.name) for st in setups])
            for f in fields(EdgeSetup)
            if f.name not in ("seg_thresholds", "seg_intercepts", "pieces")
        }
        n = config.segments
        for name, count in (("seg_thresholds", max(n - 1, 0)), ("seg_intercepts", n)):
            values[name] = tuple(
                _stack([getattr(st, name)[m] for st in setups]) for m in range(count)
            )
        pieces = [st.pieces for st in setups]
        values["pieces"] = EndPieces(
            *(_stack([getattr(p, f.name) for p in pieces]) for f in fields(EndPieces))
        )
        return cls(**values)


def _scalar(values, k: int):
    """Element k as setup gives it: a bool, a Python int, or a tuple of them."""
    if isinstance(values, tuple):
        return tuple(_scalar(v, k) for v in values)
    return bool(values[k]) if values.dtype == bool else int(values[k])


def _stack(values: list) -> np.ndarray:
    """bool array of bools; int64 array of ints that fit, else an object array of them."""
    if values and all(isinstance(v, bool) for v in values):
        return np.array(values, dtype=bool)
    if not values or min(values) >= -(1 << 63) and max(values) < (1 << 63):
        return np.array(values, dtype=np.int64)
    return np.array([int(v) for v in values], dtype=object)


def setup_int64_bits(config: EdgeConfig, i_d_max: int) -> int:
    """Bits of the largest intermediate of `setup_fields` on a batch whose largest
    |I_in - I_out| is i_d_max (the bound is derived in `setup_batch`)."""
    W, s = config.coord_bits, config.subpixel_bits
    m = max(W + s, W + 3, 2 * s + 2, s + 3, 7) + 1
    return max(i_d_max.bit_length() + config.F + m, 2 * (W + s) + 4)


def setup_batch(
    config: EdgeConfig, x0, y0, x1, y1, inside_left, i_in, i_out, clip=None, *,
    force_object: bool = False,
) -> SetupBatch:  # fmt: skip
    """`setup` of many edges at once: arrays in (one element per edge; scalars broadcast),
    a `SetupBatch` out whose ``[k]`` equals `setup` of edge k, field for field.

    Coordinates are integer arrays in sub-pixel units; inside_left a bool array (or strings
    'left' / 'right'); i_in (None: full scale) and i_out integers; clip None (`Clip.full`),
    one `Clip` for every edge, or four arrays (x_min, y_min, x_max, y_max). What `validate`
    rejects is rejected here, with EdgeError "edge k: <validate's words>" for the first bad
    edge k. force_object computes with Python ints (the fallback), for tests.

    Overflow: L = 2**(W + s) bounds the coordinates (W coord_bits, s subpixel_bits), and
    ifix = |I_in - I_out| 2**F. Coordinate terms stay below 2**(2 (W + s) + 4) (num and den of
    the first row: |v0| du + dv |c0 S - u0| < 4 L**2). Every term scaled by ifix is below
    ifix 2**(m - 1), m = max(W + s, W + 3, 2 s + 2, s + 3, 7) + 1: the divisions' numerators
    are below ifix du < ifix L; the unselected start heights half (2 v0 - (2 row0 - 1) S)
    and (end_row - row0) ifix + end_height below ifix (2**(W + 2) + 1) (rows lie within
    2**W + 1 of 0); areas kq w**2 with w <= 2 S below ifix 2**(2 s + 2); (hs0 + he) w0 below
    8 S ifix; segment intercepts below 97 ifix. Sums of two such terms stay below ifix 2**m.
    So int64 holds every intermediate when `setup_int64_bits` <= 63; otherwise the batch is
    computed on object arrays of Python ints (exact, slower): never wrapped."""
    e = _batch_inputs(config, x0, y0, x1, y1, inside_left, i_in, i_out, clip)
    i_d_max = int(np.abs(e["i_in"] - e["i_out"]).max(initial=0))
    fits = not force_object and setup_int64_bits(config, i_d_max) <= 63
    dtype = np.int64 if fits else object
    v = {name: value if value.dtype == bool else value.astype(dtype) for name, value in e.items()}
    a = ArrayArith(config, dtype)
    clip_arrays = Clip(v["x_min"], v["y_min"], v["x_max"], v["y_max"])
    names = ("x0", "y0", "x1", "y1", "inside_left", "i_in", "i_out")
    return SetupBatch(**setup_fields(a, config, *(v[n] for n in names), clip_arrays))


def _batch_inputs(config: EdgeConfig, x0, y0, x1, y1, inside, i_in, i_out, clip) -> dict:
    """The inputs of `setup_batch` as validated one-dimensional arrays of equal length:
    int64, and inside_left bool."""
    if clip is not None and not (isinstance(clip, tuple) and len(clip) == 4):
        validate_clip(config, clip)  # raises: not four bounds
    window = Clip.full(config) if clip is None else clip
    i_in = config.full_scale if i_in is None else i_in
    values = (x0, y0, x1, y1, inside, i_in, i_out, *window)
    arrays = np.broadcast_arrays(*(np.asarray(value) for value in values))
    if arrays[0].ndim != 1:
        raise ValueError(f"setup_batch takes one-dimensional arrays, not shape {arrays[0].shape}")
    names = ("x0", "y0", "x1", "y1", "inside", "i_in", "i_out", *Clip._fields)
    e = dict(zip(names, arrays, strict=True))
    first = _first_bad(config, e, clip is not None)
    if first is not None:
        _raise_for(config, e, first, clip is not None)
    out = {name: e[name].astype(np.int64) for name in names if name != "inside"}
    side = e["inside"]
    out["inside_left"] = side if side.dtype == bool else side == "left"
    return out


def _first_bad(config: EdgeConfig, e: dict, clipped: bool) -> int | None:
    """The first edge `validate` rejects (checked on whole arrays), or None."""
    hi, top, fs = config.max_vertex, 1 << config.coord_bits, config.full_scale
    bad = np.zeros(len(e["x0"]), dtype=bool)
    for name in ("x0", "y0", "x1", "y1"):
        bad |= _bad_ints(e[name], hi)
    ok = ~bad  # comparing the coordinates needs integers
    bad[ok] |= ((e["x0"][ok] == e["x1"][ok]) & (e["y0"][ok] == e["y1"][ok])).astype(bool)
    for name in Clip._fields if clipped else ():
        bad |= _bad_ints(e[name], top)
    side = e["inside"]
    if side.dtype != bool:
        known = side.dtype.kind in "UO"  # strings; other kinds are neither side
        bad |= ~((side == "left") | (side == "right")) if known else True
    bad_i = _bad_ints(e["i_in"], fs) | _bad_ints(e["i_out"], fs)
    bad |= bad_i
    ok = ~bad_i
    bad[ok] |= (e["i_in"][ok] == e["i_out"][ok]).astype(bool)
    return int(np.argmax(bad)) if bad.any() else None


def _bad_ints(values: np.ndarray, hi: int) -> np.ndarray:
    """Elements `validate` rejects as an integer in [0, hi]: out of range, or not an integer
    at all (bool, float, str elements; an object array is checked element by element)."""
    if values.dtype.kind in "iu":
        return (values < 0) | (values > hi)
    if values.dtype.kind == "O":
        return np.array(
            [isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= hi for v in values],
            dtype=bool,
        )
    return np.ones(values.shape, dtype=bool)


def _raise_for(config: EdgeConfig, e: dict, k: int, clipped: bool) -> None:
    """Raise validate's EdgeError for edge k, prefixed with its index."""
    item = {name: values[k : k + 1].tolist()[0] for name, values in e.items()}
    side = item["inside"]
    if e["inside"].dtype == bool:
        side = "left" if side else "right"
    clip = Clip(*(item[name] for name in Clip._fields)) if clipped else None
    edge = Edge(
        item["x0"], item["y0"], item["x1"], item["y1"], side, item["i_in"], item["i_out"], clip
    )
    try:
        validate(config, edge)
    except EdgeError as error:
        raise EdgeError(f"edge {k}: {error}") from None
    raise AssertionError(f"setup_batch flagged edge {k}, which validate accepts: {edge}")
