"""The task library of the KCL, one task per module; see :mod:`kcl.tasks.base`.

``TASK_TYPES`` maps the ``type:`` names used in the actions YAML to classes.
"""

from __future__ import annotations

from kcl.tasks.altitude import VehicleAltitude
from kcl.tasks.arm_velocity_minimization import ArmVelocityMinimization
from kcl.tasks.base import Param, Targets, Task, TaskContext, TaskOutput, saturate
from kcl.tasks.camera_centering import CameraCentering
from kcl.tasks.horizontal_attitude import VehicleHorizontalAttitude
from kcl.tasks.joint_limits import ArmJointLimits
from kcl.tasks.manipulability import ArmManipulability
from kcl.tasks.measured_velocity import MeasuredVehicleVelocity
from kcl.tasks.occlusion import ElbowCameraOcclusion
from kcl.tasks.preferred_shape import ArmPreferredShape
from kcl.tasks.tool_orientation import ToolOrientation
from kcl.tasks.tool_position import ToolPosition
from kcl.tasks.vehicle_pose import VehiclePositionHeading
from kcl.tasks.vehicle_velocity_minimization import VehicleVelocityMinimization

#: YAML ``type:`` name -> task class (the measured-velocity task is added by the
#: controller itself and cannot be listed in a file).
TASK_TYPES: dict[str, type[Task]] = {
    cls.TYPE: cls
    for cls in (
        ArmJointLimits,
        ArmManipulability,
        ElbowCameraOcclusion,
        CameraCentering,
        ToolPosition,
        ToolOrientation,
        ArmPreferredShape,
        VehicleHorizontalAttitude,
        VehicleAltitude,
        VehiclePositionHeading,
        VehicleVelocityMinimization,
        ArmVelocityMinimization,
    )
}

__all__ = [
    "TASK_TYPES",
    "Param",
    "Targets",
    "Task",
    "TaskContext",
    "TaskOutput",
    "saturate",
    "ArmJointLimits",
    "ArmManipulability",
    "ElbowCameraOcclusion",
    "CameraCentering",
    "ToolPosition",
    "ToolOrientation",
    "ArmPreferredShape",
    "VehicleHorizontalAttitude",
    "VehicleAltitude",
    "VehiclePositionHeading",
    "VehicleVelocityMinimization",
    "ArmVelocityMinimization",
    "MeasuredVehicleVelocity",
]
