"""Baxter hardware backend of the bridge: ROS 1 messages over Zenoh (zenoh-bridge-ros1),
safety on hardware, and a fake Baxter that speaks the same bytes for tests."""
