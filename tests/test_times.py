"""attitude/_times.py: durations written with their unit (``--stop``, ``--settle``).

Truth: the definitions of the units (a minute is 60 s, an hour 3600 s, a day 86400 s)."""

from __future__ import annotations

import math

import pytest

from attitude._times import seconds_of


@pytest.mark.parametrize(
    ("text", "seconds"),
    [("600 s", 600.0), ("10min", 600.0), ("1.5 h", 5400.0), ("2 d", 172800.0), ("250 ms", 0.25)],
)
def test_a_duration_with_its_unit_is_in_seconds(text, seconds):
    assert seconds_of(text) == seconds


@pytest.mark.parametrize("text", ["600", "3 kg", "10 deg", "abc", ""])
def test_anything_else_is_nan(text):
    assert math.isnan(seconds_of(text))  # (a plain number has no unit to say what it counts)
