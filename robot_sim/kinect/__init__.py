"""Simulated Kinect: depth images and an error-prone OpenNI-style skeleton of the handover
scene (receiver, table, object, the robot's arm). See `robot_sim.kinect.sim.KinectSim`."""

from robot_sim.kinect.camera import KinectCamera
from robot_sim.kinect.receiver import BodySize, ReceiverBody
from handover_model.robot_geometry import ArmGeometry
from robot_sim.kinect.sim import KinectFrame, KinectScenario, KinectSim, KinectTruth
from robot_sim.kinect.skeleton_model import SkeletonErrorParams

__all__ = [
    "ArmGeometry",
    "BodySize",
    "KinectCamera",
    "KinectFrame",
    "KinectScenario",
    "KinectSim",
    "KinectTruth",
    "ReceiverBody",
    "SkeletonErrorParams",
]
