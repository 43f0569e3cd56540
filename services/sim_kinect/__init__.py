"""Simulated Kinect service (`kinect`): renders the receiver, the table, the object and
the robot's arm with `robot_sim.kinect.KinectSim` at 30 Hz in its own process and publishes
`perception/skeleton`, `perception/depth` and its ground truth `sim/kinect_truth`."""
