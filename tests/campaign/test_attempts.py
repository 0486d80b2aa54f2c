"""Per-attempt scoring from a run's events (pure; event streams as the runtime emits them)."""

from mission.campaign.attempts import attempts_of_run
from mission.runtime.context import Event


def ev(t, kind, message="", **fields):
    return Event(t, kind, message, "info", fields)


def start(t):
    return ev(t, "action_start", "action grasp started", action="grasp")


def failed(t, n, at):
    return ev(t, "attempt_failed", f"attempt {n} of 3 failed at {at}: ...", attempt=n)


def test_each_way_an_attempt_ends():
    events = [
        ev(0.0, "action_start", "action survey started", action="survey"),
        # 1: reach timed out with a target -> no convergence
        start(10.0),
        ev(10.3, "target_acquired", action="grasp"),
        ev(100.0, "action_failure", "action grasp: timed out after 90.0 s (limit 90 s)", action="grasp"),
        failed(100.0, 1, "Reach the grasp frame"),
        # 2: converged, closed, the pipe squirted out -> slip
        start(101.0),
        ev(101.2, "target_acquired", action="grasp"),
        ev(130.0, "action_success", action="grasp"),
        ev(130.1, "gripper_command", "gripper close"),
        ev(131.5, "sim", "simulator: slip", sim_failed=["across"]),
        failed(132.0, 2, "Hand currents confirm the grasp"),
        # 3: the hand closes around the pipe -> success after 25 s
        start(133.0),
        ev(133.2, "target_acquired", action="grasp"),
        ev(156.0, "gripper_command", "gripper close"),
        ev(158.0, "sim", "simulator: grasp"),
        ev(160.0, "action_start", "action transport started", action="transport"),
    ]
    out = attempts_of_run(events, t_end=180.0)
    assert [a.outcome for a in out] == ["no_convergence", "slip", "success"]
    assert out[2].time_to_grasp_s == 25.0 and out[2].duration_s == 47.0
    assert out[0].time_to_grasp_s is None


def test_no_detection_closing_on_nothing_gripper_and_abort():
    events = [
        start(0.0),
        ev(90.0, "action_failure", "action grasp: timed out after 90.0 s", action="grasp"),
        failed(90.0, 1, "Reach the grasp frame"),
        start(91.0),
        ev(91.1, "target_acquired", action="grasp"),
        ev(95.0, "gripper_command", "gripper close"),
        failed(98.0, 2, "Hand currents confirm the grasp"),
        start(99.0),
        ev(99.5, "gripper_error", "gripper fault: motor"),
        failed(99.5, 3, "close"),
        start(120.0),
        ev(120.2, "target_acquired", action="grasp"),  # the run stops here (safety)
    ]
    out = attempts_of_run(events, t_end=130.0)
    assert [a.outcome for a in out] == ["not_detected", "closed_on_nothing", "gripper", "abort"]
    assert out[-1].duration_s == 10.0


def test_a_run_without_grasp_has_no_attempt_and_dict_events_work():
    assert attempts_of_run([ev(0.0, "action_start", "survey", action="survey")], 300.0) == []
    as_dicts = [
        {"t": 1.0, "kind": "action_start", "message": "", "fields": {"action": "grasp"}},
        {"t": 5.0, "kind": "sim", "message": "simulator: grasp", "fields": {}},
    ]
    assert [a.outcome for a in attempts_of_run(as_dicts, 9.0)] == ["success"]


def test_contact_offsets_are_kept():
    from mission.campaign.attempts import attempts_of_run

    events = [
        {"t": 1.0, "kind": "action_start", "fields": {"action": "grasp"}},
        {
            "t": 9.0,
            "kind": "sim",
            "message": "simulator: slip",
            "fields": {"sim_across_m": 0.061, "sim_approach_m": -0.01, "sim_position_error_m": 0.07},
        },
        {"t": 10.0, "kind": "action_start", "fields": {"action": "grasp"}},
        {
            "t": 20.0,
            "kind": "sim",
            "message": "simulator: grasp",
            "fields": {"sim_across_m": 0.01, "sim_approach_m": 0.02, "sim_position_error_m": 0.03},
        },
    ]
    a = attempts_of_run(events, 30.0)
    assert [x.outcome for x in a] == ["slip", "success"]
    assert a[0].contact == {"across_m": 0.061, "approach_m": -0.01, "position_error_m": 0.07}
    assert a[1].to_dict()["contact"]["approach_m"] == 0.02
