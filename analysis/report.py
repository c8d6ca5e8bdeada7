"""Small shared helpers: the machine record, tables and plot styling."""

from __future__ import annotations

import os
import platform

import numpy as np

from . import peers


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as file:
            for line in file:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def machine_info() -> dict[str, str]:
    info = {
        "nproc": str(os.cpu_count()),
        "cpu": cpu_model(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "platform": platform.platform(),
    }
    info.update(peers.versions())
    return info


def machine_line() -> str:
    info = machine_info()
    return "machine: " + ", ".join(f"{k} {v}" for k, v in info.items())


def table(headers: list[str], rows: list[list[str]], align: str | None = None) -> str:
    """A plain-text table (also valid Markdown when printed between pipes)."""
    widths = [
        max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(headers)
    ]
    align = align or "l" + "r" * (len(headers) - 1)

    def fmt(cells):
        out = []
        for cell, width, a in zip(cells, widths, align, strict=True):
            out.append(cell.ljust(width) if a == "l" else cell.rjust(width))
        return "| " + " | ".join(out) + " |"

    rule = (
        "| "
        + " | ".join(
            ("-" * w) if a == "l" else ("-" * (w - 1) + ":")
            for w, a in zip(widths, align, strict=True)
        )
        + " |"
    )
    return "\n".join([fmt(headers), rule, *(fmt(r) for r in rows)])


def fmt_float(value: float | None, digits: int = 6) -> str:
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return "-"
    return f"{value:.{digits}f}"


def pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save(fig, path: str) -> None:
    directory = os.path.dirname(path)
    if directory:
        os.makedirs(directory, exist_ok=True)
    fig.savefig(path, dpi=130)  # the caller names the final file (this may be a temporary)
