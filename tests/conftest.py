"""Shared test settings: deterministic hypothesis runs, headless matplotlib."""

import os

import matplotlib
from hypothesis import HealthCheck, settings

matplotlib.use("Agg")

# Seeded, repeatable property tests: the same examples on every machine and every run.
settings.register_profile(
    "labkit",
    derandomize=True,
    deadline=None,
    max_examples=int(os.environ.get("LABKIT_HYPOTHESIS_EXAMPLES", "150")),
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile("labkit")
