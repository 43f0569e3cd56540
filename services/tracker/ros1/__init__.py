"""The tracker's ROS 1 Kinect input (``sensor = "ros1"``): openni_tracker's skeleton on ``/tf``
and the depth camera's ``sensor_msgs/Image`` + ``CameraInfo``, as raw ROS 1 bytes on the Zenoh
ROS 1 bridge's keys, turned into the robot's `base` frame (docs/kinect_ros1.md)."""
