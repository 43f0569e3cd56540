"""The contracts that the services and the simulator share: the robot, the scene, the grip.

Services and simulator both import this package; services other than the bridge and the
simulated Kinect never import the simulator (`robot_sim`), and a test checks it.

Modules:
- `robots`: the arms (`RobotDescription`: URDF from `example-robot-data` placed in the scene,
  chain, tool frame, limits, gripper, giver stand-in, postures), which one this process
  drives, and their forward kinematics (pinocchio); docs/robots.md;
- `robot_geometry`: the robot arm as capsules at a joint configuration (what a camera sees of it);
- `shapes`: capsules and their distances;
- `scene`: the handover scene's layout (table, object, task plane) in the robot's base frame;
- `grip`: the grip controller's interface (sensor sample, command, mode) that the gripper
  service implements and the contact simulator runs.
"""
