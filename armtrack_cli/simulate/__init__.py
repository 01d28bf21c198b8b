"""Simulated sessions with exact truth: arm kinematics, IMU physics, camera rendering,
Qualisys markers. Pure functions on arrays; the pipeline writes the files."""
