"""Protocol peers for tests and dry runs without hardware, each a process
speaking the real wire format: ``cia402_sim`` (CANopen CiA 402 drives on
canopen's LocalNode), ``ardusub_peer`` (MAVLink, ArduSub-like),
``nav_sensor_sim`` (Water Linked DVL over TCP or a pty, MicroStrain MIP AHRS
over a pty), ``reach_peer`` (a Reach Alpha 5 / Bravo 7 arm, Reach serial
protocol over a pty or UDP), ``ping_peer`` (a Blue Robotics Ping echosounder,
ping protocol over a pty or UDP). :mod:`hal.testing.peers` starts and stops them.
"""
