"""Edge commands and the per-edge setup: octant folding, increments and the initial value.

Everything here runs once per edge; it may multiply and divide (the hardware uses a
sequential divider). The per-column loop in `step.py` uses only what `setup` returns.
Coordinates are image coordinates (x right, y down, pixel (x, y) centred on integers) in
sub-pixel units: a vertex coordinate X means X / 2**subpixel_bits pixels.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, NamedTuple

from .column import IntArith
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
    the top (smaller v) of the stepping loop's row; docs/algorithm.md section 8 derives each.

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


def end_pieces(config: EdgeConfig, f: Fold, w: Window, st_values: dict, inside_left) -> EndPieces:
    """The per-edge constants of `EndPieces` (divisions and small products: setup only).

    st_values holds the setup's columns, row0 (folded), jq, jr, kq, khq, khr, du, i_d and
    the edge's screen dy."""
    s, F, S = config.subpixel_bits, config.F, config.subpixel_scale
    v = st_values
    columns, row0, i_d, du = v["columns"], v["row0"], v["i_d"], v["du"]
    jq, jr, khq, khr = v["jq"], v["jr"], v["khq"], v["khr"]
    ifix = i_d << F
    half = i_d << (F - s - 1)  # ifix per half sub-pixel step (F > s: exact)
    first_partial = columns > 0 and not w.start_clip
    last_partial = columns > 0 and w.last == f.c1
    single = columns == 1 and first_partial and last_partial
    # In half sub-pixel steps (2 S per pixel, so that a pixel's edges are whole numbers):
    mg = 2 * f.u0 - (2 * w.first - 1) * S if first_partial else 0  # from column start to u0
    me = (2 * w.last + 1) * S - 2 * f.u1 if last_partial else 0  # from u1 to column end
    v1 = f.v0 + f.dv  # folded, both axes increase from P0 to P1
    if first_partial:
        hs0 = half * (2 * f.v0 - (2 * row0 - 1) * S)
    else:  # a whole column: floor(J - K/2)
        hs0 = jq - khq - (1 if jr < khr else 0)
    end_row = (2 * v1 + S) >> (s + 1)
    end_height = half * (2 * v1 - (2 * end_row - 1) * S)
    # Areas of partial pieces use K's quotient kq: within one unit, and no new division.
    kq, sq = v["kq"], 2 * s + 3  # K w^2 / 2 with w over 2 S: (kq w^2) >> (2 s + 3)
    he_first = jq + khq + (1 if jr + khr >= du else 0)  # floor(J + K/2) of the first column
    if single:
        he_first = end_height + (end_row - row0) * ifix
    w0 = 2 * S - mg - (me if single else 0)  # the first piece's width, 2 S per pixel
    w1 = 2 * S - me
    if f.x_major:
        total0 = (kq * ((2 * S - mg) ** 2 - (me**2 if single else 0))) >> sq
        total1 = (kq * (4 * S * S - me * me)) >> sq
        rect0 = (max(-hs0, 0) * mg) >> (s + 1)
        rect1 = (end_height * me) >> (s + 1)
        band0 = band1 = 0
    else:
        total0 = ((hs0 + he_first) * w0) >> (s + 2)
        total1 = ((end_height * w1) >> (s + 1)) - ((kq * w1 * w1) >> sq)
        rect0 = rect1 = 0
        band0, band1 = half * w0, half * w1
    # Travelling down the screen with the inside on the left puts the inside on the +x side.
    sigma = 1 if (v["dy"] > 0) == bool(inside_left) else -1
    return EndPieces(
        sigma, row0, first_partial, last_partial, hs0, end_row, end_height,
        total0, total1, rect0, rect1, band0, band1,
    )  # fmt: skip


_SELECTS = IntArith()


def setup(config: EdgeConfig, edge: Edge) -> EdgeSetup:
    """Fold the edge into the first octant and compute the loop's constants and start state."""
    validate(config, edge)
    s, F, S = config.subpixel_bits, config.F, config.subpixel_scale
    a = _SELECTS  # fold and window only select: no register is checked here
    i_in, i_out = edge.intensities(config)
    f = fold(a, config, edge.x0, edge.y0, edge.x1, edge.y1, i_in, i_out, edge.inside == "left")
    w = window(a, f, edge.window(config))
    columns = max(w.last - w.first + 1, 0)
    clipped_start = columns > 0 and w.start_clip
    c0 = w.first if columns else f.c0  # an empty cut keeps c0

    # Line height at the centre of column c0: vc = num / den pixels.
    num = f.v0 * f.du + f.dv * (c0 * S - f.u0)
    den = S * f.du
    row0 = floor_div(2 * num + den, 2 * den)  # row whose span [y - 1/2, y + 1/2) holds vc
    mf = 2 * num + den - 2 * row0 * den  # f = vc - (row0 - 1/2) = mf / (2 den), in [0, 1)

    i_d, du = f.i_d, f.du
    jq, jr = divmod(i_d * mf << (F - s - 1), du)
    kq, kr = divmod(i_d * f.dv << F, du)
    khq, khr = divmod(i_d * f.dv << (F - 1), du)
    if config.accumulator == "truncated":
        jr = kr = khr = 0  # the paper's fixed point: remainders dropped
    thresholds, intercepts = segment_constants(config, kq)

    step_major, step_minor = -1 if f.major_neg else 1, -1 if f.minor_neg else 1

    def screen(major: int, minor: int) -> tuple[int, int]:
        return (major, minor) if f.x_major else (minor, major)

    x, y = screen(step_major * c0, step_minor * row0)
    col_dx, col_dy = screen(step_major, 0)
    row_dx, row_dy = screen(0, step_minor)
    values = dict(
        columns=columns,
        row0=row0,
        jq=jq,
        jr=jr,
        kq=kq,
        khq=khq,
        khr=khr,
        du=du,
        i_d=i_d,
        dy=edge.y1 - edge.y0,
    )
    pieces = end_pieces(config, f, w, values, edge.inside == "left")
    return EdgeSetup(
        x_major=f.x_major,
        columns=columns,
        clipped_start=clipped_start,
        x=x,
        y=y,
        col_dx=col_dx,
        col_dy=col_dy,
        row_dx=row_dx,
        row_dy=row_dy,
        du=du,
        dv=f.dv,
        ifix=i_d << F,
        jq=jq,
        jr=jr,
        kq=kq,
        kr=kr,
        khq=khq,
        khr=khr,
        value_base=f.value_base,
        value_sign=-1 if f.value_neg else 1,
        inside_is_a=f.inside_is_a,
        seg_thresholds=thresholds,
        seg_intercepts=intercepts,
        pieces=pieces,
    )
