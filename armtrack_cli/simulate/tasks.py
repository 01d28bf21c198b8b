"""The tasks the simulator knows, by name: the CLI offers them without loading the simulator."""

ARM_TASKS = ("circle", "rectangle", "reach", "figure8")  # IMU + wrist patch sessions
HAND_TASKS = ("wrist-rom", "reach-grasp", "wrist-deviation", "wrist-flexion")  # palm markers + depth
