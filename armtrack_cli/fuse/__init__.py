"""Stage: IMU + camera detections fused into wrist (and elbow) trajectories: Tao & Hu's
inertial-only, EKF, UKF, bootstrap PF and layered-sampling PF with the arm constraint."""
