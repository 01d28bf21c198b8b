"""Filters in textbook symbols (x, P, F, Q, H, R), independent of arms and cameras:
Gaussian filters (KF, EKF, UKF), particle sets and resampling. numpy only."""
