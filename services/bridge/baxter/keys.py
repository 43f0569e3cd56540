"""Zenoh keys of ROS 1 topics, as the Zenoh ROS 1 bridge (zenoh-plugin-ros1) names them.

zenoh-plugin-ros1 / zenoh-bridge-ros1 (since 0.11) publishes a ROS 1 topic on the key

    <hex(datatype)>/<md5sum>[/<bridge_ns>]/<topic without the leading '/'>

where ``hex(datatype)`` is the type name (``sensor_msgs/JointState``) hex-encoded because a
key chunk cannot hold ``/``, and ``bridge_ns`` is the bridge's optional namespace (its
``BRIDGE_NAMESPACE``/``--bridge_namespace`` setting). The payload is the message's raw ROS 1
serialisation. Older plugin versions used the bare topic (``robot/joint_states``); the
``plain`` format reproduces that, with an optional prefix. Both are configurable in
``[services.bridge.config.baxter]`` (``key_format``, ``key_namespace``).
"""

from __future__ import annotations

from typing import Literal

from services.bridge.baxter.errors import BaxterConfigError
from services.bridge.baxter.ros1 import md5sum

KeyFormat = Literal["plugin", "plain"]


def topic_key(topic: str, type_name: str, key_format: KeyFormat = "plugin", namespace: str = "") -> str:
    """The Zenoh key carrying ROS 1 `topic` of type `type_name`.

    Args:
        topic: ROS 1 topic name, e.g. ``/robot/joint_states``.
        type_name: ROS 1 type, e.g. ``sensor_msgs/JointState``.
        key_format: ``plugin`` (hex type / md5 / [ns] / topic) or ``plain`` ([ns] / topic).
        namespace: the bridge namespace (plugin) or key prefix (plain); empty for none.

    Raises:
        BaxterConfigError: an empty topic or a name with Zenoh wildcard characters.
    """
    name = topic.strip("/")
    ns = namespace.strip("/")
    for part, what in ((name, "topic"), (ns, "key namespace")):
        if any(c in part for c in "*$?#") or "//" in part:
            raise BaxterConfigError(f"{what} {part!r} holds a character Zenoh keys cannot use")
    if not name:
        raise BaxterConfigError("a ROS topic name is empty")
    if key_format == "plugin":
        parts = [type_name.encode().hex(), md5sum(type_name)]
        if ns:
            parts.append(ns)
        parts.append(name)
        return "/".join(parts)
    if key_format == "plain":
        return f"{ns}/{name}" if ns else name
    raise BaxterConfigError(f"unknown key_format {key_format!r} (plugin or plain)")
