"""Offline studies of the tracker (see `services.studies`)."""
