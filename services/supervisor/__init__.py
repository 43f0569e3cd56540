"""Supervisor: sequences the handover, enforces the release interrupt, watches the services."""
