"""shadowsurvey sim_harness: the software vehicle the product is dry-run against.

Sub-packages, one idea each:

- :mod:`sim_harness.world`: seabed, relief, texture, target solids;
- :mod:`sim_harness.sonar`: the sonar renderer, scene files, viewpoints, each frame's truth;
- :mod:`sim_harness.vehicle`: dynamics, sensors, low-level control;
- :mod:`sim_harness.simulator`: the assembled software ROV (vehicle, autopilot, socket, sonar);
- :mod:`sim_harness.autopilot`: the ArduSub 4.5-like autopilot behind a MAVLink socket;
- :mod:`sim_harness.clock`, :mod:`sim_harness.faults`: simulated time and fault injection.

It talks to the vehicle side only through MAVLink bytes; its truth goes to scorers only.
"""
