"""Scenario files: shipped ones load, errors name file:line:column and field,
overrides, sampling from the seed, pickling."""

from __future__ import annotations

import pickle

import pytest

from maris_common.yamlsrc import ConfigError
from sim_backend import Range, available_scenarios, load_scenario
from sim_backend.scenario import sample_values


def test_shipped_scenarios_load():
    names = available_scenarios()
    for required in ("pool_clear", "pool_turbid", "pool_no_dvl"):
        assert required in names
    for name in names:
        sc = load_scenario(name)
        assert sc.name == name
    assert load_scenario("pool_no_dvl")["dvl.present"] is False
    assert load_scenario("pool_clear")["dvl.present"] is True
    # pool_no_dvl extends pool_clear: it inherits the randomized pipe pose
    assert isinstance(load_scenario("pool_no_dvl")["pipe.x_m"], Range)


def test_unknown_name_lists_shipped():
    with pytest.raises(ConfigError) as e:
        load_scenario("pool_cler")
    assert "pool_clear" in str(e.value)


def write(tmp_path, text):
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    return p


def test_errors_name_file_line_column_and_field(tmp_path):
    p = write(
        tmp_path,
        "extends: pool_clear\n"
        "dvl:\n"
        "  noise_std_mps: -1\n"
        "  rate_hz: fast\n"
        "vision:\n"
        "  turbidity: murky\n"
        "  fov_hrad: 1.0\n"
        "pipe:\n"
        "  x_m: {min: 5, max: 2}\n"
        "vehical:\n"
        "  actuated: [true]\n",
    )
    with pytest.raises(ConfigError) as e:
        load_scenario(p)
    text = str(e.value)
    lines = text.splitlines()
    assert len(e.value.issues) == 6, text
    # marks point at the offending value
    assert f"{p}:3:18: dvl.noise_std_mps:" in text and "outside" in text
    assert f"{p}:4:12: dvl.rate_hz:" in text
    assert f"{p}:6:14: vision.turbidity:" in text and "clear" in text
    assert f"{p}:7:13: vision.fov_hrad:" in text and "fov_h_rad" in text  # suggestion
    assert f"{p}:9:8: pipe.x_m:" in text and "greater than max" in text
    assert f"{p}:11:3: vehical:" in text and "vehicle" in text
    assert all(line.startswith(str(p)) for line in lines)


def test_cross_check_and_bad_extends(tmp_path):
    p = write(tmp_path, "vision:\n  min_range_m: 7.0\n  max_range_m: 6.0\n")
    with pytest.raises(ConfigError, match=r"bad.yaml:2:16: vision.min_range_m: must be smaller"):
        load_scenario(p)
    p = write(tmp_path, "extends: pool_clear\npipe:\n  x_m: {min: 20, max: 26}\n")
    with pytest.raises(ConfigError, match=r"bad.yaml:3:8: pipe.x_m: must lie inside the pool"):
        load_scenario(p)
    p = write(tmp_path, "extends: nothing_like_this\n")
    with pytest.raises(ConfigError, match=r"bad.yaml:1:10: extends: no scenario named"):
        load_scenario(p)
    p = write(tmp_path, "- just\n- a list\n")
    with pytest.raises(ConfigError, match="mapping of sections"):
        load_scenario(p)
    p = write(tmp_path, "dvl: {present: yes please}\n")
    with pytest.raises(ConfigError, match=r"bad.yaml:1:16: dvl.present: expected true or false"):
        load_scenario(p)


def test_yaml_syntax_error_is_config_error(tmp_path):
    p = write(tmp_path, "dvl:\n  present: [true\n")
    with pytest.raises(ConfigError, match="bad.yaml:"):
        load_scenario(p)


def test_overrides_dotted_and_textual():
    sc = load_scenario(
        "pool_clear",
        {"dvl.noise_std_mps": "0.02", "pipe.x_m": {"min": 10, "max": 11}, "vision.turbidity": "very_turbid"},
    )
    assert sc["dvl.noise_std_mps"] == 0.02
    assert sc["pipe.x_m"] == Range(10.0, 11.0)
    assert sc["vision.turbidity"] == "very_turbid"
    sc = load_scenario("pool_clear", {"vision.detection_probability.clear": "0.8"})
    assert sc["vision.detection_probability"] == {"clear": 0.8, "slightly_turbid": 0.5, "very_turbid": 0.03}
    with pytest.raises(ConfigError, match="did you mean `clear`"):
        load_scenario("pool_clear", {"vision.detection_probability.cleer": 0.8})
    with pytest.raises(ConfigError) as e:
        load_scenario("pool_clear", {"dvl.noise_std": 0.02, "ahrs.rate_hz": -5})
    text = str(e.value)
    assert "<override>" in text and "dvl.noise_std_mps" in text and "ahrs.rate_hz" in text


def test_scenario_pickles():
    sc = load_scenario("pool_turbid", {"dvl.dropouts": [[1.0, 2.0]]})
    again = pickle.loads(pickle.dumps(sc))
    assert again == sc
    assert again["dvl.dropouts"] == ((1.0, 2.0),)


def test_sampling_is_seeded_and_within_ranges():
    sc = load_scenario("pool_turbid")
    a, b, c = sample_values(sc, 1), sample_values(sc, 1), sample_values(sc, 2)
    assert a == b
    assert a != c
    xs = [sample_values(sc, s)["pipe.x_m"] for s in range(50)]
    assert min(xs) >= 11.5 and max(xs) <= 13.5 and max(xs) - min(xs) > 1.0
    levels = {sample_values(sc, s)["vision.turbidity"] for s in range(50)}
    assert levels == {"slightly_turbid", "very_turbid"}


@pytest.mark.parametrize("seed", [-1, 2.5, "7", True])
def test_bad_seed_is_a_config_error(seed):
    with pytest.raises(ConfigError) as err:
        sample_values(load_scenario("pool_clear"), seed)
    assert "seed: must be a non-negative integer" in str(err.value)


def test_adding_a_random_parameter_keeps_other_draws():
    base = sample_values(load_scenario("pool_clear"), 3)
    more = sample_values(load_scenario("pool_clear", {"pipe.float_height_m": {"min": 0.02, "max": 0.1}}), 3)
    assert base["pipe.x_m"] == more["pipe.x_m"] and base["vehicle.start_x_m"] == more["vehicle.start_x_m"]


def test_fixed_scenario_is_fixed():
    sc = load_scenario("pool_fixed")
    assert not sc.randomized
    assert sample_values(sc, 1) == sample_values(sc, 99)


def test_per_turbidity_tables_can_be_partial(tmp_path):
    p = write(tmp_path, "extends: pool_clear\nvision:\n  detection_probability: {slightly_turbid: 0.3}\n")
    assert load_scenario(p)["vision.detection_probability"] == {
        "clear": 0.95,
        "slightly_turbid": 0.3,
        "very_turbid": 0.03,
    }
    p = write(tmp_path, "vision:\n  visibility_m: {murky: 0.3}\n")
    with pytest.raises(ConfigError, match=r"bad.yaml:2:25: vision.visibility_m.murky: unknown turbidity"):
        load_scenario(p)


def test_vehicle_model_parameters_are_checked_with_file_and_line(tmp_path):
    p = tmp_path / "bad_dynamics.yaml"
    p.write_text(
        "extends: pool_clear\n"
        "vehicle:\n"
        "  model: fulll\n"
        "  added_mass: [1, 2, 3]\n"
        "thrusters:\n"
        "  dead_zone: 1.5\n"
        "dcl:\n"
        "  bandwith_rad_s: [1, 1, 1, 1, 1, 1]\n"
        "grasp:\n"
        "  position_tolerance_m: 0.03\n"
    )
    with pytest.raises(ConfigError) as e:
        load_scenario(p)
    text = str(e.value)
    assert f"{p}:4:" in text and "vehicle.added_mass: expected a list of 6 numbers" in text
    assert f"{p}:6:" in text and "thrusters.dead_zone: 1.5 is outside [0, 0.9]" in text
    assert f"{p}:8:" in text and "did you mean `bandwidth_rad_s`" in text
    assert f"{p}:10:" in text and "across_tolerance_m" in text  # the old rule is gone; the new ones are listed
    with pytest.raises(ConfigError) as e:  # a bad model name is a cross-check, once the rest is valid
        load_scenario("pool_clear", {"vehicle.model": "fulll"})
    assert "unknown vehicle model 'fulll' (did you mean `full`?)" in str(e.value)
    assert load_scenario("pool_oct2015")["diver.hold"] is True
    assert load_scenario("pool_clear", {"vehicle.model": "first_order"})["vehicle.model"] == "first_order"
