"""Offline studies of the gripper (see `services.studies`)."""
