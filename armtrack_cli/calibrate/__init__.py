"""Stage: the camera's intrinsics and its pose in W from the board on the table."""
