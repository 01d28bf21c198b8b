"""Writers of the recorded formats armtrack reads (Xsens MT Manager text, generic IMU CSV,
ROS 2 MCAP, Qualisys TSV, video): used by `simulate` to write sessions that the readers in
session/ must take as real ones."""
