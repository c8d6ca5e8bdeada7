"""`python -m edgeaa.sim.verification.formal [proof ...]`."""

from . import main

raise SystemExit(main())
