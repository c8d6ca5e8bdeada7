"""The bit-accurate integer model of the edge antialiaser: the golden reference."""

from .config import ACCUMULATORS, MODES, ConfigError, EdgeConfig, RegisterWidth
from .edge import Clip, Edge, EdgeError, EdgeSetup, setup, validate
from .reference import error_bound, exact_coverage, exact_coverage_array
from .step import EdgeResult, StepState, WidthError, Write, run_edge

__all__ = [
    "ACCUMULATORS",
    "MODES",
    "Clip",
    "ConfigError",
    "Edge",
    "EdgeConfig",
    "EdgeError",
    "EdgeResult",
    "EdgeSetup",
    "RegisterWidth",
    "StepState",
    "WidthError",
    "Write",
    "error_bound",
    "exact_coverage",
    "exact_coverage_array",
    "run_edge",
    "setup",
    "validate",
]
