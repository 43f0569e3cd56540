"""Shared service plumbing: profiles, loopback-only Zenoh sessions, typed pub/sub, loops,
liveliness, structured logging and the common CLI."""

from services.runtime.cli import EXIT_BAD_INPUT, EXIT_FAILURE, EXIT_OK, base_parser, load_profile, run_main
from services.runtime.errors import BusError, ProfileError, ServiceError
from services.runtime.liveliness import LivelinessWatcher, alive_services
from services.runtime.logs import RateLimitedLog, kv, setup_logging
from services.runtime.loop import RateLoop
from services.runtime.node import Received, ServiceNode, TypedPublisher, TypedSubscription, open_session
from services.runtime.profile import Profile, ServiceSpec, load_profile_file
from services.runtime.zenoh_config import zenoh_config, zenoh_config_dict

__all__ = [
    "EXIT_BAD_INPUT",
    "EXIT_FAILURE",
    "EXIT_OK",
    "BusError",
    "LivelinessWatcher",
    "Profile",
    "ProfileError",
    "RateLimitedLog",
    "RateLoop",
    "Received",
    "ServiceError",
    "ServiceNode",
    "ServiceSpec",
    "TypedPublisher",
    "TypedSubscription",
    "alive_services",
    "base_parser",
    "kv",
    "load_profile",
    "load_profile_file",
    "open_session",
    "run_main",
    "setup_logging",
    "zenoh_config",
    "zenoh_config_dict",
]
