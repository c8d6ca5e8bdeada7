# amaranth: UnusedElaboratable=no
"""The core's interface: ports and payload layouts, the stepper's registers against the
width table, no multiplier or divider, the Verilog ports and the Verilator lint.
"""

from __future__ import annotations

import re

import pytest
from amaranth.back import rtlil
from amaranth.hdl import Shape, Value, signed, unsigned
from amaranth.lib.wiring import In, Out
from fixtures import CORE_CONFIGS, core_config_params

from edgeaa.hdl import LineCore, LineStepper, clip_layout, verilog
from edgeaa.model import Clip
from edgeaa.sim.simulators.verilator import lint
from edgeaa.sim.synthesis import muldiv_cells

# -- (1) interface ---------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["default", "small"])
def test_interface(name):
    config = CORE_CONFIGS[name]
    W, s = config.coord_bits, config.subpixel_bits
    I = config.intensity_bits  # noqa: E741
    dut = LineCore(config)
    members = dut.signature.members
    assert set(members) == {"edges", "clip", "writes", "errors", "error"}
    assert members["edges"].flow == In and members["writes"].flow == Out
    assert members["errors"].flow == Out and members["errors"].shape == unsigned(16)
    assert members["error"].flow == Out and members["error"].shape == unsigned(1)
    # The clip window: four pixel bounds in [0, 2**W]; undriven, it clips nothing.
    assert members["clip"].flow == In and members["clip"].shape == clip_layout(config)
    bounds = {key: Shape.cast(fld.shape) for key, fld in clip_layout(config)}
    assert bounds == {key: unsigned(W + 1) for key in ("x_min", "y_min", "x_max", "y_max")}
    clip = clip_layout(config).from_bits(Value.cast(dut.clip).init)
    assert [clip[key] for key, _ in clip_layout(config)] == list(Clip.full(config))
    edges = members["edges"].signature.members
    assert set(edges) == {"payload", "valid", "ready"}
    layout = edges["payload"].shape
    assert {key: Shape.cast(fld.shape) for key, fld in layout} == {
        "x0": unsigned(W + s),
        "y0": unsigned(W + s),
        "x1": unsigned(W + s),
        "y1": unsigned(W + s),
        "i_in": unsigned(I),
        "i_out": unsigned(I),
        "inside": unsigned(1),
    }
    out = members["writes"].signature.members["payload"].shape
    assert [key for key, _ in out] == ["lane0", "lane1", "lane1_valid", "last"]
    pixel = {"x": signed(W + 2), "y": signed(W + 2), "value": unsigned(I)}
    for lane in ("lane0", "lane1"):
        assert {key: Shape.cast(fld.shape) for key, fld in out[lane].shape} == pixel
    assert Shape.cast(out["lane1_valid"].shape) == unsigned(1)
    assert Shape.cast(out["last"].shape) == unsigned(1)
    with pytest.raises(TypeError, match="config must be an EdgeConfig"):
        LineCore({"coord_bits": 11})
    with pytest.raises(TypeError, match="errors_bits must be a positive integer, not 0"):
        LineCore(config, errors_bits=0)


@pytest.mark.parametrize("name", core_config_params())
def test_stepper_registers_use_the_width_table(name):
    config = CORE_CONFIGS[name]
    stepper = LineCore(config).stepper
    for reg_name, width in config.register_widths().items():
        sig = getattr(stepper, reg_name, None)
        if sig is None:  # a combinational value of the loop: checked in the RTLIL below
            continue
        assert sig.shape() == (signed if width.signed else unsigned)(width.bits), reg_name
    for sig in stepper.seg_thresholds + stepper.seg_intercepts:
        assert sig.shape() == unsigned(config.register_widths()["seg_const"].bits)
    text = rtlil.convert(stepper, emit_src=False)
    for wire_name, key in (("jsum", "jsum"), ("dq", "dq"), ("t", "t"), ("area0", "area")):
        if config.segments == 0 and key in ("dq", "t"):
            continue
        width = config.register_widths()[key]
        assert re.search(rf"wire width {width.bits} (signed )?\\{wire_name}\n", text), wire_name


# -- (8) no multiplier or divider in the stepping loop ---------------------------------------


@pytest.mark.parametrize("name", core_config_params())
def test_stepper_has_no_multiplier_or_divider(name):
    assert muldiv_cells(LineStepper(CORE_CONFIGS[name])) == {}


def test_setup_uses_bit_serial_units():
    # Not a requirement (the setup may multiply), but the design has no $mul/$div at all.
    assert muldiv_cells(LineCore(CORE_CONFIGS["seg4"])) == {}


# -- Verilog ---------------------------------------------------------------------------------


def test_verilog_ports():
    text = verilog(CORE_CONFIGS["default"])
    header = re.search(r"module edgeaa_core\((.*?)\);", text, re.S).group(1)
    ports = {port.strip() for port in header.split(",")}
    assert ports == {
        "clk",
        "rst",
        "edges__valid",
        "edges__ready",
        *(f"edges__payload__{name}" for name in ("x0", "y0", "x1", "y1", "i_in", "i_out")),
        "edges__payload__inside",
        "writes__valid",
        "writes__ready",
        *(f"writes__payload__{lane}__{name}" for lane in ("lane0", "lane1") for name in "xy"),
        "writes__payload__lane0__value",
        "writes__payload__lane1__value",
        "writes__payload__lane1_valid",
        "writes__payload__last",
        *(f"clip__{name}" for name in ("x_min", "y_min", "x_max", "y_max")),
        "errors",
        "error",
    }
    assert "input [14:0] edges__payload__x0;" in text
    assert "input [11:0] clip__x_max;" in text
    assert "output signed [12:0] writes__payload__lane1__y;" in text
    assert "output [7:0] writes__payload__lane1__value;" in text


@pytest.mark.parametrize("name", ["default", "seg4", "small"])
def test_verilog_lints(name):
    """verilator --lint-only -Wall, with the targeted waiver file `edgeaa verilog` writes."""
    proc = lint(verilog(CORE_CONFIGS[name]))
    assert proc.returncode == 0, proc.stdout + proc.stderr
