"""A TMDS encoder (DVI 1.0, section 3.3): one 10-bit word per pixel clock from a byte while
``de`` is high, or a control token from ``control`` (C0 | C1 << 1) while it is low. The
reference is `edgeaa.model.video.tmds_encode` (tested word for word, and the running disparity
``cnt`` against the model's, from every state the encoder can reach).

The word is registered: it appears one clock after its inputs. The running disparity is
even and within [-8, 8] (reachable states of the model), so 5 signed bits hold it.
"""

from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux, Signal, signed
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ..model.video import CONTROL_TOKENS

__all__ = ["TMDSEncoder"]


def _ones(m: Module, value) -> Signal:
    """Ones in `value`, as a 4-bit count."""
    count = Signal(4)
    m.d.comb += count.eq(sum(value[i] for i in range(len(value))))
    return count


class TMDSEncoder(wiring.Component):
    def __init__(self):
        super().__init__({"data": In(8), "control": In(2), "de": In(1), "word": Out(10)})
        self.cnt = Signal(signed(5))  # running disparity, observed by the test

    def elaborate(self, platform):
        m = Module()
        d = self.data
        n1_d = _ones(m, d)
        xnor = (n1_d > 4) | ((n1_d == 4) & ~d[0])
        q = [d[0]]
        for i in range(1, 8):
            q.append(Signal(name=f"q{i}"))
            m.d.comb += q[i].eq(Mux(xnor, ~(q[i - 1] ^ d[i]), q[i - 1] ^ d[i]))
        q_m = Cat(*q)
        q_m8 = ~xnor
        ones = _ones(m, q_m)
        diff = Signal(signed(5))  # ones - zeros of q_m's 8 bits
        m.d.comb += diff.eq(2 * ones - 8)
        cnt = self.cnt
        with m.If(~self.de):
            m.d.sync += cnt.eq(0)
            with m.Switch(self.control):
                for c, token in enumerate(CONTROL_TOKENS):
                    with m.Case(c):
                        m.d.sync += self.word.eq(token)
        with m.Elif((cnt == 0) | (diff == 0)):
            m.d.sync += self.word.eq(Cat(Mux(q_m8, q_m, ~q_m), q_m8, ~q_m8))
            m.d.sync += cnt.eq(cnt + Mux(q_m8, diff, -diff))
        with m.Elif(((cnt > 0) & (diff > 0)) | ((cnt < 0) & (diff < 0))):
            m.d.sync += self.word.eq(Cat(~q_m, q_m8, 1))
            m.d.sync += cnt.eq(cnt + 2 * q_m8 - diff)
        with m.Else():
            m.d.sync += self.word.eq(Cat(q_m, q_m8, 0))
            m.d.sync += cnt.eq(cnt - 2 * ~q_m8 + diff)
        return m
