"""The step gate: the drivers' threads wait out the control loop's step (no timing asserted)."""

from __future__ import annotations

import threading

from hal.drivers.realtime import StepGate, TickPacer


def test_a_reader_waits_while_the_gate_is_closed_and_goes_on_when_it_opens() -> None:
    gate = StepGate(max_hold=60.0)  # far longer than the test: only open() can release the reader
    passed = threading.Event()

    def reader() -> None:
        gate.wait()
        passed.set()

    gate.close()
    th = threading.Thread(target=reader, daemon=True)
    th.start()
    assert not passed.wait(0.2)  # held back while the step runs
    gate.open()
    assert passed.wait(10.0)
    th.join(10.0)
    gate.wait()  # open: returns at once
    assert not gate.closed


def test_the_wait_is_bounded_when_the_loop_never_opens_the_gate() -> None:
    gate = StepGate(max_hold=0.05)
    gate.close()
    passed = threading.Event()
    th = threading.Thread(target=lambda: (gate.wait(), passed.set()), daemon=True)
    th.start()
    assert passed.wait(10.0)  # a blocked loop never starves a reader
    gate.close()  # already closed: no deadlock on the loop thread
    gate.open()
    gate.open()  # idempotent


def test_the_pacer_opens_the_gate_for_its_sleep_and_closes_it_for_the_step(fake_clock) -> None:  # noqa: ANN001
    clock = fake_clock
    gate = StepGate(max_hold=60.0)
    seen: list[bool] = []

    def sleep(dt: float) -> None:
        seen.append(gate.closed)
        clock.sleep(dt)

    pacer = TickPacer(clock, sleep=sleep, gate=gate, gate_lead=0.001)
    pacer.advance(0.01)
    assert gate.closed  # the step that follows runs with the gate closed
    seen.clear()
    pacer.advance(0.01)
    assert seen == [False, True]  # open while waiting, closed for the last gate_lead s before the tick
    assert abs(clock.now() - 0.02) < 1e-12 and gate.closed
    clock.t += 0.05  # a step far past its tick: no sleep, the next step still runs gated
    pacer.advance(0.01)
    assert gate.closed and pacer.overruns == 1
    gate.open()


def test_a_drives_lock_free_joint_values_agree_with_its_problem_report() -> None:
    """Cia402Drive.joint_values (read every control step without the lock) gives the same
    values as reading() and calls a drive usable exactly when problem() finds nothing."""
    import itertools

    import canopen

    from hal.drivers.canopen_drive import Cia402Drive, DriveParams
    from hal.testing.field_rig import EDS

    t = [0.0]
    params = DriveParams(node_id=5, counts_per_rad=1000.0, velocity_units_per_rad_s=100.0, max_velocity=1.0)
    statuswords = (0x0237, 0x0208, 0x0250, 0x0207)  # OPERATION ENABLED, FAULT, SWITCH ON DISABLED, QUICK STOP
    drive = Cia402Drive(canopen.Network(), str(EDS), params, lambda: t[0], "j5")
    for on_change, sw, hb_age, pdo_age, nmt, latched in itertools.product(
        (False, True), statuswords, (None, 0.0, 0.29, 0.31), (None, 0.0, 0.19, 0.21), (0x05, 0x7F), (None, "x")
    ):
        with drive._lock:  # as built: nothing received yet
            drive._sw, drive._state, drive._t_status, drive._t_position, drive._nmt, drive._hb_t = (
                0,
                None,
                None,
                None,
                "UNKNOWN",
                None,
            )
            drive._publish()
        drive._on_change = on_change
        drive._fault_latched = latched
        now = 10.0
        if pdo_age is not None:
            with drive._lock:
                drive._apply_values({0x6041: sw, 0x6064: 1234, 0x606C: -50}, now - pdo_age)
        if hb_age is not None:
            t[0] = now - hb_age
            drive._on_heartbeat(0x705, bytearray([nmt]), 0.0)
        position, velocity, current, t_position, usable = drive.joint_values(now)
        r = drive.reading()
        assert (position, velocity, t_position) == (r.position, r.velocity, r.t_position)
        assert current != current and r.current != r.current  # no rated current: NaN
        assert usable == (drive.problem(now) is None), (on_change, sw, hb_age, pdo_age, nmt, latched)
