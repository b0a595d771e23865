"""The arms: one registry, each arm's kinematics and check, and the program formats it takes.

A room of ``rap.robot``, one idea a module:

* ``registry``: every arm as data (kinematic model, joint limits, speeds, accelerations, jerks,
  reach, repeatability, formats) and the one export vocabulary ``FORMATS``;
* ``ur``: UR forward kinematics from the pinned DH rows, the analytic IK (``ur-analytic-ik``),
  branches and singularity margins; ``ur_check``: a program on one branch, 1 mm samples;
  ``urscript``: the UR program with joint targets; ``ur_model``: the UR in pybullet;
* ``trajectory``: the Panda's program timed by Ruckig within its limits; ``ros``: as ROS 2
  JointTrajectory segments (YAML, JSON);
* ``export``: the door from a program to a checked file for its arm (``check_arm``, ``render``).

Importing this package imports nothing else; cost: none.
"""
