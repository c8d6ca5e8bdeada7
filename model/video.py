"""The board's video output as a model: the 640 x 480 at 60 Hz timing (`VideoTiming`, `VGA`)
and TMDS encoding as the DVI 1.0 specification gives it (section 3.3, figure 3-5), the
reference `edgeaa.hdl.tmds.TMDSEncoder` is tested against.

A TMDS word is 10 bits, bit 0 sent first. While data is enabled, a byte is first made
transition-minimised (XOR or XNOR chain, bit 8 says which), then sent as it is or inverted
(bit 9 says which) so that the running disparity (ones minus zeros sent since the last
control period, `TMDSState.cnt`) stays bounded: DC balance. During blanking one of four
control tokens carries two control bits (the blue channel's are hsync and vsync) and the
disparity restarts at 0.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "CONTROL_TOKENS",
    "VGA",
    "TMDSState",
    "VideoTiming",
    "tmds_decode",
    "tmds_encode",
    "tmds_stream",
]

# (C1, C0) -> the token (DVI 1.0, 3.3.3): index c = C0 | C1 << 1.
CONTROL_TOKENS = (0b1101010100, 0b0010101011, 0b0101010100, 0b1010101011)


@dataclass(frozen=True)
class VideoTiming:
    """One video mode: per axis the active pixels, front porch, sync and back porch; sync
    pulses are active low when `*_negative` (640 x 480 has both negative)."""

    width: int
    h_front: int
    h_sync: int
    h_back: int
    height: int
    v_front: int
    v_sync: int
    v_back: int
    pixel_hz: float
    h_negative: bool = True
    v_negative: bool = True

    @property
    def h_total(self) -> int:
        return self.width + self.h_front + self.h_sync + self.h_back

    @property
    def v_total(self) -> int:
        return self.height + self.v_front + self.v_sync + self.v_back

    @property
    def frame_clocks(self) -> int:
        return self.h_total * self.v_total

    @property
    def refresh_hz(self) -> float:
        return self.pixel_hz / self.frame_clocks

    def sync(self, h: int, v: int) -> tuple[int, int]:
        """The hsync and vsync levels at counter position (h, v)."""
        in_h = self.width + self.h_front <= h < self.width + self.h_front + self.h_sync
        in_v = self.height + self.v_front <= v < self.height + self.v_front + self.v_sync
        return int(in_h != self.h_negative), int(in_v != self.v_negative)


# 640 x 480 at 60 Hz (VESA DMT), run from the board's 25 MHz: 59.5 Hz, within monitors' range.
VGA = VideoTiming(640, 16, 96, 48, 480, 10, 2, 33, pixel_hz=25e6)


def _ones(value: int, bits: int = 8) -> int:
    return bin(value & ((1 << bits) - 1)).count("1")


@dataclass
class TMDSState:
    """The encoder's running disparity: ones minus zeros sent since the last control word."""

    cnt: int = 0


def tmds_encode(state: TMDSState, de: int, data: int, control: int) -> int:
    """One TMDS word (DVI 1.0 figure 3-5); updates `state`. `control` is C0 | C1 << 1."""
    if not de:
        state.cnt = 0
        return CONTROL_TOKENS[control & 3]
    d = [(data >> i) & 1 for i in range(8)]
    n1 = sum(d)
    xnor = n1 > 4 or (n1 == 4 and d[0] == 0)
    q = [d[0]]
    for i in range(1, 8):
        bit = q[i - 1] ^ d[i]
        q.append(1 - bit if xnor else bit)
    q_m8 = 0 if xnor else 1
    q_m = sum(b << i for i, b in enumerate(q))
    ones = _ones(q_m)
    zeros = 8 - ones
    if state.cnt == 0 or ones == zeros:
        invert = not q_m8
        state.cnt += (ones - zeros) if q_m8 else (zeros - ones)
    elif (state.cnt > 0 and ones > zeros) or (state.cnt < 0 and zeros > ones):
        invert = True
        state.cnt += 2 * q_m8 + zeros - ones
    else:
        invert = False
        state.cnt += -2 * (1 - q_m8) + ones - zeros
    low = (~q_m & 0xFF) if invert else q_m
    return low | q_m8 << 8 | int(invert) << 9


def tmds_decode(word: int) -> tuple[int, int | None]:
    """(data, None) of a data word, or (0, control) of a control token."""
    if word in CONTROL_TOKENS:
        return 0, CONTROL_TOKENS.index(word)
    q = (~word & 0xFF) if word >> 9 & 1 else word & 0xFF
    xor = word >> 8 & 1
    data = q & 1
    for i in range(1, 8):
        bit = ((q >> i) ^ (q >> (i - 1))) & 1
        data |= (bit if xor else 1 - bit) << i
    return data, None


def tmds_stream(symbols) -> tuple[list[int], list[int]]:
    """The words of (de, data, control) symbols from a fresh encoder, and the running
    disparity after each."""
    state, words, disparity = TMDSState(), [], []
    for de, data, control in symbols:
        words.append(tmds_encode(state, de, data, control))
        disparity.append(state.cnt)
    return words, disparity
