"""What every measure shares: its settings and the 'not computable' signal."""

from __future__ import annotations

from dataclasses import dataclass


class NotComputable(ValueError):
    """The measure has no value for this input; the message says why, in plain words."""


# Measures of one movement: a session of several has them for each segment only (a SPARC or
# an LDLJ of many movements and the rests between them is no movement's smoothness, and would
# cost an FFT and a jerk integral as long as the session for every posterior draw).
ONE_MOVEMENT = ("time_to_peak_speed", "sparc", "ldlj")


@dataclass(frozen=True)
class Settings:
    onset_fraction: float = 0.02  # onset/offset at 2 % of peak speed (Alt Murphy et al. 2011)
    lowpass_hz: float = 6.0  # positions: 4th-order zero-phase Butterworth (Winter 2009)
    max_gap_s: float = 0.5  # longest interior gap bridged (PCHIP) before a measure refuses
    min_moving_speed: float = 0.01  # m/s: below this peak the wrist did not move
    min_segment_s: float = 0.3  # a run above the onset threshold shorter than this is no movement
    min_segment_peak: float = 0.2  # … and one whose peak is below 20 % of the session peak
    segment_fraction: float = 0.10  # repetitions are split where speed < 10 % of the session peak
    mu_rise: float = 0.020  # m/s: movement-unit rise, local minimum to next maximum (Alt Murphy 2011)
    mu_min_gap_s: float = 0.150  # s between movement-unit peaks (Alt Murphy 2011)
    sparc_fc_hz: float = 10.0  # SPARC cut-off (Balasubramanian et al. 2015)
    sparc_amp_th: float = 0.05  # SPARC amplitude threshold
    sparc_pad: int = 4  # zero padding to 2^(ceil(log2 N) + 4)
    min_reach_m: float = 0.02  # straightness needs start and end this far apart
    plane_min_elevation_deg: float = 10.0  # plane of elevation undefined closer to gimbal lock
    neutral_s: float = 1.0  # the first second is the neutral pose for relative angles
    draws: int = 40  # posterior draws for uncertainty
    draw_corr_s: float = 1.0  # correlation time of the estimation error (Gaussian); measured 0.5-1.9 s
    #                           on the simulated circle-01 (pf-constraint), docs/measures.md
    seed: int = 0


DEFAULT = Settings()
