"""Example budgets that follow the active Hypothesis profile.

A test that needs fewer (slow body) or more examples than the profile's default asks for ``examples(n)``:
``n`` under the default ``ci`` profile (300 examples), scaled in proportion under ``thorough`` (5000), so
``HYPOTHESIS_PROFILE=thorough`` really runs every property harder.
"""

from hypothesis import settings

CI_EXAMPLES = 300


def examples(n: int) -> int:
    """``n`` examples under the ``ci`` profile, scaled by the active profile's budget otherwise."""
    return max(1, round(n * settings().max_examples / CI_EXAMPLES))
