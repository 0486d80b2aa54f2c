"""Perception for the field: stereo calibration and the MARIS pipe detector.

A pure package (functions of images and calibrations, no device I/O), like
:mod:`kcl`; it may use :mod:`kcl` (the arm model for occlusion masks) and never
imports :mod:`mission`. Modules:

* :mod:`vision.calibration` - camera models; OpenCV FileStorage, ROS camera_info, Kalibr files.
* :mod:`vision.rectify` - stereo rectification maps.
* :mod:`vision.colour` - colour restoration (grey world, veil removal).
* :mod:`vision.silhouette` - one image: HSV colour region, straight edges, end outlines.
* :mod:`vision.cylinder` - tangent planes, the cylinder axis, the pipe end.
* :mod:`vision.occlusion` - the arm's reprojection mask (through :class:`kcl.model.UvmsModel`).
* :mod:`vision.detector` - the detector: pair in, :class:`~vision.detector.PipeDetection` out.
* :mod:`vision.monocular` - the detector on one camera.
* :mod:`vision.tracking` - the grasp frame filtered over detections.
* :mod:`vision.pipeline` - the detector with the vehicle around it (arm, attitude, vehicle frame).
* :mod:`vision.overlay` - drawings for operators (ROI, edges, axis, grasp frame).

Frames: camera frames are OpenCV optical frames (x right, y down, z forward);
the left camera frame is the rig frame, the URDF's ``stereo_camera``.
"""
