"""Motion service: PlaCo IK and Ruckig trajectories for the robot's arm (thesis §4.1).

Import the pieces from their modules: `config.MotionConfig`, `ik.ArmIk`, `paths`,
`core.MotionController`, `preview.preview`; errors derive from `errors.MotionError`.
"""

from services.motion.errors import MotionError

__all__ = ["MotionError"]
