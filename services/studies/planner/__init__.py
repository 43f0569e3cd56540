"""Offline studies of the planner (see `services.studies`)."""
