"""Offline studies of the motion (see `services.studies`)."""
