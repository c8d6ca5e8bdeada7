"""`python -m edgeaa.sim.verification.formal [proof ...]`."""

from .run import main

raise SystemExit(main())
