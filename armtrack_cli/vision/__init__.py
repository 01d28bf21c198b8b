"""Camera geometry that more than one stage needs (calibrate finds the board, simulate draws
it): OpenCV-backed, below the stages, above core."""
