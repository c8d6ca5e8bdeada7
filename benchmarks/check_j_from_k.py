"""Check the J-from-K identity of docs/hardware.md (setup throughput): jq, jr from kq, kr,
the start offset e and row0, with no second long division (`python
benchmarks/check_j_from_k.py`; default configuration, unclipped edges, seed 7)."""

import random

from edgeaa.model import Edge, EdgeConfig, EdgeError, setup
from edgeaa.model.edge import _SELECTS, fold


def main(count: int = 20000, seed: int = 7) -> None:
    config = EdgeConfig()
    rng = random.Random(seed)
    s, F = config.subpixel_bits, config.F
    S, hi = 1 << s, config.max_vertex
    checked = 0
    for _ in range(count):
        x0, y0 = rng.randint(0, hi), rng.randint(0, hi)
        reach = rng.choice([64, 1000, hi])
        x1 = min(hi, max(0, x0 + rng.randint(-reach, reach)))
        y1 = min(hi, max(0, y0 + rng.randint(-reach, reach)))
        edge = Edge(x0, y0, x1, y1, i_in=rng.randint(0, 255), i_out=rng.randint(0, 255))
        try:
            st = setup(config, edge)
        except EdgeError:
            continue
        f = fold(_SELECTS, config, x0, y0, x1, y1, *edge.intensities(config), True)
        e = f.c0 * S - f.u0  # |e| <= S / 2
        a, b = divmod(e * st.kq, S)
        z, rest = divmod(b * f.du + e * st.kr, S)
        assert rest == 0, edge
        zq, zr = divmod(z, f.du)
        assert zq in (-1, 0, 1), edge
        h0 = 2 * f.v0 + S - 2 * S * st.pieces.row0
        assert ((f.i_d * h0) << (F - s - 1)) + a + zq == st.jq and zr == st.jr, edge
        checked += 1
    print(f"J from K holds on {checked} random edges (default configuration, seed {seed})")


if __name__ == "__main__":
    main()
