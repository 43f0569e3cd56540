"""Franka (Panda / FR3) hardware backend of the bridge: libfranka through `franky-control`,
tested against `franky-sim` (a simulator that speaks libfranka's network protocol)."""
