"""The comparison is bit for bit by default, or within a stated relative tolerance;
`--set` options are checked like every other user input."""

from __future__ import annotations

import math

import pytest

from maris_common.yamlsrc import ConfigError
from mission.replay.compare import first_difference
from mission.replay.settings import NO_FILTER_CUTOFF_RAD_S, parse_settings


def test_bit_for_bit_by_default():
    assert first_difference({"v": [1.0, 2.0]}, {"v": [1.0, 2.0]}) is None
    assert first_difference({"v": [1.0, 2.0]}, {"v": [1.0, math.nextafter(2.0, 3.0)]}) == (
        "v[1]",
        2.0,
        math.nextafter(2.0, 3.0),
    )
    assert first_difference([0.0], [-0.0]) == ("[0]", 0.0, -0.0)  # the sign of zero counts (atan2 sees it)
    assert first_difference([math.nan], [math.nan]) is None
    assert first_difference({"a": 1, "b": {"c": "x"}}, {"a": 1, "b": {"c": "y"}}) == ("b.c", "x", "y")
    assert first_difference({"a": True}, {"a": 1}) == ("a", True, 1)
    assert first_difference([1, 2], [1, 2, 3]) == (" length", 2, 3)
    assert first_difference({"a": 1}, {"a": 1, "b": 2}) == ("b", "<absent>", 2)


def test_relative_tolerance_for_other_machines():
    a, b = 0.123456789, 0.123456789 * (1 + 3e-12)
    assert first_difference([a], [b], 1e-9) is None
    assert first_difference([1e-13], [-1e-13], 1e-9) is None  # small values: absolute 1e-9
    assert first_difference([0.1], [0.1 + 1e-6], 1e-9) is not None
    assert first_difference(["grasp"], ["transport"], 1e-3) is not None  # decisions always exactly
    assert first_difference([math.inf], [math.inf], 1e-9) is None and first_difference([math.inf], [1e308], 1e-9)


def test_settings_parse_and_explain():
    s = parse_settings(
        [
            "controller.filter_cutoff_rad_s=.inf",
            "controller.compensation=false",
            "controller.vehicle_velocity_limit=[0.3, 0.3, 0.2, 0.1, 0.1, 0.2]",
            "controller.lam=null",
        ]
    )
    assert s == {
        "filter_cutoff_rad_s": NO_FILTER_CUTOFF_RAD_S,
        "compensation": False,
        "vehicle_velocity_limit": (0.3, 0.3, 0.2, 0.1, 0.1, 0.2),
        "lam": None,
    }
    assert parse_settings(["controller.filter_cutoff_rad_s=25"]) == {"filter_cutoff_rad_s": 25.0}
    assert parse_settings(["controller.filter_cutoff_rad_s=off"]) == {"filter_cutoff_rad_s": NO_FILTER_CUTOFF_RAD_S}
    with pytest.raises(ConfigError, match="positive number"):
        parse_settings(["controller.filter_cutoff_rad_s=-3"])
    with pytest.raises(ConfigError) as err:
        parse_settings(["controller.filter_cutof_rad_s=3", "controller.compensation=maybe", "scenario.x=1", "nokey"])
    text = str(err.value)
    assert (
        "--set:1:1: controller.filter_cutof_rad_s: unknown setting (did you mean controller.filter_cutoff_rad_s?)"
        in text
    )
    assert "--set:2:25: controller.compensation: expected true or false, got 'maybe'" in text
    assert "--set:3:1" in text and "--set:4:1" in text
    with pytest.raises(ConfigError, match="six positive numbers"):
        parse_settings(["controller.vehicle_velocity_limit=[1, 2]"])


def test_no_filter_is_the_same_cutoff_as_the_runs_and_campaigns():
    from mission.campaign.single import NO_FILTER_CUTOFF_RAD_S as campaign
    from mission.commands._runner import controller_cutoff

    assert NO_FILTER_CUTOFF_RAD_S == campaign == controller_cutoff(math.inf)


def test_fields_only_newer_code_logs_are_listed_not_divergences() -> None:
    """A log written by older code lacks fields the replay's code adds: with
    ``new_fields`` they are collected (indices and mapping keys folded) and the
    rest is still compared; without it they are a difference."""
    from mission.replay.compare import _collapse

    old = {"t": 1.0, "tasks": {"a": {"error": [0.1]}, "b": {"error": [0.2]}}}
    new = {"t": 1.0, "tasks": {"a": {"error": [0.1], "rate": [0.0]}, "b": {"error": [0.2], "rate": [1.0]}}, "why": {}}
    assert first_difference(old, new) == ("tasks.a.rate", "<absent>", [0.0])
    added: set[str] = set()
    assert first_difference(old, new, 0.0, "", added) is None
    assert _collapse(added) == ["tasks.*.rate", "why"]
    changed = {"t": 1.0, "tasks": {"a": {"error": [0.3], "rate": [0.0]}, "b": {"error": [0.2]}}}
    assert first_difference(old, changed, 0.0, "", set()) == ("tasks.a.error[0]", 0.1, 0.3)
    missing = {"t": 1.0, "tasks": {"a": {"error": [0.1]}}}  # a field the replay lacks is always a difference
    assert first_difference(old, missing, 0.0, "", set()) == ("tasks.b", {"error": [0.2]}, "<absent>")
