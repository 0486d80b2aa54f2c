"""Run planning (seeds) and --set parsing."""

import pytest

from maris_common.yamlsrc import ConfigError
from mission.campaign.overrides import parse_settings
from mission.campaign.plan import plan_campaign, run_seeds
from mission.runtime.options import RunOptions


def test_seeds_deterministic_and_prefix_stable():
    a = run_seeds(7, 10)
    assert a == run_seeds(7, 10)
    assert run_seeds(7, 3) == a[:3]  # run i's seed does not depend on N
    assert len(set(a)) == 10
    assert run_seeds(8, 10) != a
    assert all(0 <= s < 2**32 for s in a)


def test_plan_carries_settings_and_log_paths(tmp_path):
    plan = plan_campaign(
        "m.yaml",
        "pool_clear",
        12,
        3,
        overrides={"turbidity": 0.2},
        controller={"compensation": False},
        log_dir=tmp_path,
    )
    assert [r.index for r in plan.runs] == list(range(12))
    assert plan.runs[11].log_path == str(tmp_path / "run_0011.mcap")
    assert all(r.overrides == {"turbidity": 0.2} and r.controller == {"compensation": False} for r in plan.runs)
    assert [r.seed for r in plan.runs] == run_seeds(3, 12)


def test_negative_inputs_rejected():
    with pytest.raises(ValueError):
        run_seeds(-1, 3)


def test_set_values_are_yaml_scalars():
    s = parse_settings(
        [
            "pipe.yaw_deg=[-10, 10]",
            "turbidity=0.4",
            "controller.compensation=false",
            "controller.filter_cutoff_rad_s=.inf",
            "name=abc",
            "noise.enabled=yes",
        ]
    )
    assert s.scenario == {"pipe.yaw_deg": [-10, 10], "turbidity": 0.4, "name": "abc", "noise.enabled": True}
    assert s.controller == {"compensation": False, "filter_cutoff_rad_s": float("inf")}


def test_set_errors_all_at_once_with_position():
    with pytest.raises(ConfigError) as err:
        parse_settings(
            [
                "ok=1",
                "novalue",
                "controller.compensaton=true",
                "controller.filter_cutoff_rad_s=-3",
                "x=[1, 2",
                "controller.compensation=maybe",
            ]
        )
    text = str(err.value)
    assert len(err.value.issues) == 5
    assert "--set:2:1" in text and "expected key=value" in text
    assert "did you mean controller.compensation" in text
    assert "--set:4:" in text and "positive number" in text
    assert "--set:5:" in text and "not valid YAML" in text
    assert "--set:6:" in text and "true or false" in text


def test_set_never_evaluates():
    with pytest.raises(ConfigError, match="not valid YAML"):
        parse_settings(["a=!!python/object/apply:os.system ['echo hi']"])


def test_disabled_filter_passes_samples_unchanged():
    import math

    import numpy as np

    from kcl.filters import FirstOrderLowPass
    from mission.campaign.single import run_options

    for disabled in (None, math.inf):
        opts = run_options({"compensation": True, "filter_cutoff_rad_s": disabled})
        assert opts.compensation is True
        f = FirstOrderLowPass(opts.filter_cutoff, 6)
        rng = np.random.default_rng(0)
        f.update(np.zeros(6), 0.0)
        for k in range(1, 50):
            x = rng.standard_normal(6)
            np.testing.assert_allclose(f.update(x, k * 1e-6), x, rtol=0, atol=1e-15)  # even at 1 us steps
    assert run_options({"filter_cutoff_rad_s": 50.0}, "r.mcap") == RunOptions(log_path="r.mcap", filter_cutoff=50.0)
