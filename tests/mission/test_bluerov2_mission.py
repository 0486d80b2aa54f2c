"""One mission tree, two rigs: the model and actions come from data (the mission, the
HAL config, the scenario: mission.platform), disagreements name both places, and the
shipped BlueROV2 mission dry-runs to success."""

from __future__ import annotations

from pathlib import Path

import pytest

from hal.config import load_hal_config
from maris_common.yamlsrc import ConfigError
from mission.cli import main
from mission.compiler import compile_abort, compile_mission
from mission.loader import load_mission
from sim_backend import load_scenario

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "kcl" / "data"
ALPHA = DATA / "bluerov2_heavy_alpha5.urdf"
ALPHA_ACTIONS = DATA / "bluerov2_alpha5_actions.yaml"
R2 = DATA / "r2_uma.urdf"
BLUE_SIM = ROOT / "hal" / "configs" / "bluerov2_sim.yaml"
MARIS = ROOT / "missions" / "maris_pipe_recovery.yaml"
BLUE_MISSION = ROOT / "missions" / "bluerov2_pipe_grasp.yaml"


def line_of(path: Path, needle: str) -> int:
    return next(i for i, ln in enumerate(path.read_text().splitlines(), 1) if needle in ln)


def test_the_hal_config_names_the_rig_of_a_mission_without_one() -> None:
    mission = load_mission(BLUE_MISSION, BLUE_SIM)
    assert mission.model == ALPHA.resolve() and mission.actions_file == ALPHA_ACTIONS.resolve()
    assert "reach" in mission.action_names  # the Alpha's actions file was read
    default = load_mission(BLUE_MISSION, ROOT / "hal" / "configs" / "sim.yaml")
    assert default.model is None and default.actions_file is None  # the shipped R2 rig


def test_the_scenario_names_the_rig_of_a_dry_run() -> None:
    mission = load_mission(BLUE_MISSION, ROOT / "hal" / "configs" / "sim.yaml", scenario=load_scenario("bluerov2_pool"))
    assert mission.model == ALPHA.resolve() and mission.actions_file == ALPHA_ACTIONS.resolve()


def test_the_missions_own_fields_take_precedence(tmp_path: Path) -> None:
    text = BLUE_MISSION.read_text().replace(
        "rates: {", f"model: {R2}\nactions_file: {DATA / 'actions.yaml'}\nrates: {{", 1
    )
    path = tmp_path / "m.yaml"
    path.write_text(text)
    mission = load_mission(path, BLUE_SIM)  # the simulator's arm takes its joints from the model: no clash
    assert mission.model == R2 and mission.actions_file == DATA / "actions.yaml"


def test_a_scenario_of_another_rig_is_refused_naming_both_places(tmp_path: Path) -> None:
    text = BLUE_MISSION.read_text().replace("rates: {", f"model: {R2}\nrates: {{", 1)
    path = tmp_path / "m.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as exc:
        load_mission(path, scenario=load_scenario("bluerov2_pool"))
    msg = str(exc.value)
    scen = ROOT / "sim_backend" / "scenarios" / "bluerov2_pool.yaml"
    assert f"{path}:{line_of(path, 'model:')}:8: model" in msg
    assert f"{scen}:{line_of(scen, 'model: bluerov2_heavy_alpha5.urdf')}" in msg
    assert "r2_uma.urdf" in msg and "bluerov2_heavy_alpha5.urdf" in msg


def test_a_hal_arm_whose_joints_are_not_the_models_names_both_places(tmp_path: Path) -> None:
    """The Alpha 5's field config naming the R2 model: the arm's joints are not that URDF's."""
    field = ROOT / "hal" / "configs" / "bluerov2_alpha5_serial.yaml"
    text = field.read_text().replace("../../kcl/data/", f"{DATA}/")
    text = text.replace(f"model: {ALPHA}", f"model: {R2}").replace(f"actions: {ALPHA_ACTIONS}", "")
    cfg = tmp_path / "field.yaml"
    cfg.write_text(text)
    with pytest.raises(ConfigError) as exc:
        load_mission(ROOT / "missions" / "vehicle_check.yaml", cfg)
    msg = str(exc.value)
    assert f"{cfg}:{line_of(cfg, '  arm:') + 1}:5: devices.arm.joints: the HAL arm has 4 joint(s)" in msg
    assert f"the model r2_uma.urdf named by the HAL config ({cfg}:{line_of(cfg, 'model:')}:8: model)" in msg


def test_the_maris_reference_tree_compiles_on_the_bluerov2_rig() -> None:
    """The same behaviours (survey, grasp, lift, transport, hold) exist in the Alpha's
    actions file: the R2 mission loads and compiles against it. (Its gripper leaves ask
    for the hand's `cylindrical` preshape and two loaded motor groups, which the jaw
    does not have: docs/bluerov2.md.)"""
    mission = load_mission(MARIS, BLUE_SIM)
    assert mission.model == ALPHA.resolve()
    assert compile_mission(mission, None) is not None and compile_abort(mission, None) is not None
    ours = load_mission(BLUE_MISSION, ROOT / "hal" / "configs" / "sim.yaml")  # and ours on the R2 rig
    assert compile_mission(ours, None) is not None


@pytest.mark.slow
def test_the_shipped_bluerov2_mission_dry_runs_to_success(tmp_path: Path, capsys) -> None:
    """maris sim with the BlueROV2 simulator HAL config (its scenario, its rig), default seed."""
    log = tmp_path / "run.mcap"
    code = main(["sim", str(BLUE_MISSION), "--hal", str(BLUE_SIM), "--log", str(log), "--quiet"])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "succeeded" in out and "holding" in out and log.exists()


def test_maris_sim_refuses_a_hal_config_with_real_devices(capsys) -> None:
    code = main(["sim", str(BLUE_MISSION), "--hal", str(ROOT / "hal" / "configs" / "bluerov2_sim_arm.yaml")])
    assert code == 2 and "not every role is `driver: sim`" in capsys.readouterr().err


def test_the_field_config_of_the_alpha_checks_against_the_rig() -> None:
    """bluerov2_alpha5_serial.yaml names its rig: a mission checks against the Alpha URDF."""
    cfg = load_hal_config(ROOT / "hal" / "configs" / "bluerov2_alpha5_serial.yaml")
    mission = load_mission(ROOT / "missions" / "vehicle_check.yaml", cfg)
    assert mission.model == ALPHA.resolve()
