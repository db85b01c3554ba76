"""Suite-wide settings: Hypothesis judges no test by the machine's speed.

Its per-example deadline and its too-slow health check time examples on the wall clock, so
on a loaded machine (or beside another pytest worker) they fail tests that are correct.
"""

from __future__ import annotations

from hypothesis import HealthCheck, settings

settings.register_profile("simbridge", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("simbridge")
