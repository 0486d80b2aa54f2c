"""Real device drivers behind :mod:`hal.interfaces`.

One module per job:

* ``realtime`` - monotonic backend clock and tick pacing; ``backend`` - the real
  :class:`~hal.interfaces.Backend`;
* ``cia402`` - the CiA 402 power state machine (host planner + device model);
  ``canbus`` - one shared CANopen network with its service thread and echo
  filter; ``canopen_drive`` - one CiA 402 drive in profile velocity mode;
  ``arm_canopen`` / ``gripper_canopen`` - the arm and gripper devices on it;
* ``ardusub`` - MAVLink link to ArduSub; ``dvl_waterlinked`` - Water Linked
  DVL A50 (TCP JSON, serial wrz); ``ahrs_microstrain`` - MicroStrain MIP AHRS;
  ``ping_altimeter`` - Blue Robotics Ping echosounder (altitude);
  ``vehicle_ardusub`` - the vehicle device combining them;
* ``reach_protocol`` / ``reach_link`` / ``reach_guardian`` / ``reach_device`` -
  the Reach serial protocol, its serial/UDP link and the process that stops the
  arm when ours dies; ``reach_arm`` / ``reach_jaw`` - the arm and its jaw;
* ``setup_checks`` - set-up errors found at connect, naming the config field.

Simulated peers speaking the same protocols live in :mod:`hal.testing`.
Importing this package imports nothing heavy; import the modules you need.
"""
