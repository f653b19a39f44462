"""Test-suite settings.

Hypothesis runs derandomized (its examples are a function of the test, not of
the run), so the suite gives the same verdict on every machine and every run;
set ``HYPOTHESIS_PROFILE=explore`` to search with fresh random examples.
"""

import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
